"""The SB3 callbacks of a training run (:func:`baselines.run.train_agent`): evaluation, checkpoints, progress.

Imported when a run starts (Stable-Baselines3 is the ``rl`` extra). Each callback holds the run
(``baselines.run._Run``): its plan (frequencies, the warm start, the progress bar), its
evaluations, and its ``evaluate`` and ``checkpoint`` methods.
"""

from __future__ import annotations

from typing import Any

from stable_baselines3.common.callbacks import BaseCallback


class _RunCallback(BaseCallback):
    """A callback bound to one training run."""

    def __init__(self, run: Any) -> None:
        super().__init__()
        self.run, self.plan = run, run.plan

    def _on_step(self) -> bool:
        return True


class ProgressBar(_RunCallback):
    """The harness's progress bar over environment steps: done/total, elapsed, ETA, last evaluation."""

    bar: Any = None

    def _on_training_start(self) -> None:
        from uav_penetration_env.benchmark.progress import ProgressBar as Bar

        self.bar = Bar(self.plan.total_timesteps, f"train {self.plan.algo}", unit="steps")
        self.bar.update(int(self.model.num_timesteps))  # a resumed run starts where it stopped

    def _on_step(self) -> bool:
        self.bar.update(min(self.training_env.num_envs, self.plan.total_timesteps - self.bar.n))
        if self.run.evaluations:
            last = self.run.evaluations[-1]
            self.bar.set_postfix(eval_return=f"{last['mean_return']:.2f}", success=f"{last['success_rate']:.0%}")
        return True

    def _on_training_end(self) -> None:
        self.close()

    def close(self) -> None:
        """Stop drawing (also when Ctrl-C ends ``learn`` before ``_on_training_end``)."""
        if self.bar is not None:
            self.bar.close()


class Periodic(_RunCallback):
    """Evaluate and checkpoint every ``eval_freq`` / ``checkpoint_freq`` environment steps.

    Both happen at the start of a rollout, i.e. right after the update that used every step
    counted so far (mid-rollout, PPO's policy would still be the one before its last update).
    """

    def _on_training_start(self) -> None:
        # After a resume: the next multiples after the last evaluation and the checkpoint's steps.
        plan = self.plan
        last_eval = int(self.run.evaluations[-1]["timesteps"]) if self.run.evaluations else 0
        steps = int(self.model.num_timesteps)
        self.next_eval = (last_eval // plan.eval_freq + 1) * plan.eval_freq if plan.eval_freq else 0
        self.next_checkpoint = (
            (steps // plan.checkpoint_freq + 1) * plan.checkpoint_freq if plan.checkpoint_freq else 0
        )

    def _on_rollout_start(self) -> None:
        plan, steps = self.plan, self.model.num_timesteps
        if plan.eval_freq and steps >= self.next_eval:
            self.run.evaluate()
            self.next_eval = (steps // plan.eval_freq + 1) * plan.eval_freq
        if plan.checkpoint_freq and steps >= self.next_checkpoint:
            self.run.checkpoint()
            self.next_checkpoint = (steps // plan.checkpoint_freq + 1) * plan.checkpoint_freq


class CriticWarmup(_RunCallback):
    """Keep the actor frozen for the warm start's first steps, so only the critic learns (docs/rl.md §6.5).

    The freeze is set or lifted at the start of each rollout, from the step count, so a resumed
    run is frozen exactly when the run it continues would be.
    """

    def _set(self) -> None:
        from baselines.warm_start import set_actor_trainable

        warm = self.plan.warm_start
        assert warm is not None
        set_actor_trainable(self.model, self.model.num_timesteps >= warm.critic_warmup_steps)

    def _on_training_start(self) -> None:
        self._set()

    def _on_rollout_start(self) -> None:
        self._set()


class StartEvaluation(_RunCallback):
    """A warm-started run's curve starts with the network it was given (an evaluation at step 0)."""

    def _on_training_start(self) -> None:
        if self.plan.eval_freq and not self.run.evaluations and self.model.num_timesteps == 0:
            self.run.evaluate()


__all__ = ["CriticWarmup", "Periodic", "ProgressBar", "StartEvaluation"]
