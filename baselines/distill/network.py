"""The learner: a small MLP on the env's observation, its fit, and its weights as plain arrays.

The weights travel as float32 NumPy arrays (``W0, b0, W1, b1, ...`` plus the observation's
``obs_mean`` and ``obs_scale``): a saved network is an ``.npz`` that holds no pickle, its SHA-256
names it, and :func:`forward` flies it with NumPy alone, so a distilled policy is scored without
torch. Torch is imported only to fit (inside the functions: ``baselines.plugin`` imports this
package's policy module, and must import without the rl extra).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

Arrays = dict[str, np.ndarray]
PRIOR_LOG_WEIGHT = float(np.log(10.0))  # the value prior's first weight: 1 J of V ahead is 10 logits


def layer_count(arrays: Mapping[str, np.ndarray]) -> int:
    """How many linear layers the arrays hold (``W0`` ... ``W{n-1}``)."""
    count = 0
    while f"W{count}" in arrays:
        count += 1
    return count


def outputs(arrays: Mapping[str, np.ndarray], observations: np.ndarray) -> np.ndarray:
    """The last linear layer's values (n, outputs) for observations (n, 67), in float64, unclipped."""
    x = (np.asarray(observations, dtype=np.float64) - arrays["obs_mean"]) / arrays["obs_scale"]
    last = layer_count(arrays) - 1
    for i in range(last + 1):
        x = x @ arrays[f"W{i}"].astype(np.float64).T + arrays[f"b{i}"]
        if i < last:
            x = np.tanh(x)
    return x


def forward(arrays: Mapping[str, np.ndarray], observations: np.ndarray) -> np.ndarray:
    """The network's outputs (n, 3) in [-1, 1] for observations (n, 67), computed in float64.

    DECISION (docs/rl.md §4.2): tanh hidden layers, a linear output clipped to the action box
    [-1, 1]: the expert's actions sit on the bounds (full turns, full acceleration), which a tanh
    output reaches only asymptotically and which an MSE fit then pulls inwards.
    """
    return np.clip(outputs(arrays, observations), -1.0, 1.0)


def observation_scaling(observations: np.ndarray, ignored: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Per-slot mean and scale of the round-0 observations; a constant slot gets scale 1.

    ``ignored`` (a boolean mask over the slots) blinds slots: their mean is 0 and their scale
    infinite, so their normalised input is 0 whatever the observation holds (docs/rl.md §4.8),
    in the fit and in flight alike, and the saved arrays (hashed) say which slots were blinded.

    DECISION (docs/rl.md §4.2): the scaling is computed once, from the expert's own round-0
    states, and frozen: the later rounds warm-start from the previous network, whose first layer
    would otherwise see its inputs move under it.
    """
    mean = observations.mean(axis=0)
    std = observations.std(axis=0)
    scale = np.where(std > 1e-6, std, 1.0)
    if ignored is not None:
        mean = np.where(ignored, 0.0, mean)
        scale = np.where(ignored, np.inf, scale)
    return mean.astype(np.float32), scale.astype(np.float32)


def action_spread(actions: np.ndarray) -> np.ndarray:
    """Each action channel's spread in the labels (std, at least 0.01 of the [-1, 1] range)."""
    return np.maximum(np.asarray(actions, dtype=np.float64).std(axis=0), 0.01).astype(np.float32)


def _torch() -> Any:
    try:
        import torch
    except ImportError as error:  # pragma: no cover - depends on the installed extras
        from baselines.install import RL_INSTALL

        raise ImportError(f"distillation needs torch: {RL_INSTALL} ({error})") from error
    return torch


def _build(torch: Any, n_in: int, hidden: Sequence[int], n_out: int) -> Any:
    layers: list[Any] = []
    width = n_in
    for h in hidden:
        layers += [torch.nn.Linear(width, h), torch.nn.Tanh()]
        width = h
    layers.append(torch.nn.Linear(width, n_out))
    return torch.nn.Sequential(*layers)


def _linears(net: Any) -> list[Any]:
    return [m for m in net if m.__class__.__name__ == "Linear"]


def _to_arrays(net: Any, mean: np.ndarray, scale: np.ndarray) -> Arrays:
    arrays: Arrays = {"obs_mean": mean, "obs_scale": scale}
    for i, linear in enumerate(_linears(net)):
        arrays[f"W{i}"] = linear.weight.detach().numpy().astype(np.float32).copy()
        arrays[f"b{i}"] = linear.bias.detach().numpy().astype(np.float32).copy()
    return arrays


def _load_arrays(torch: Any, net: Any, arrays: Mapping[str, np.ndarray]) -> None:
    with torch.no_grad():
        for i, linear in enumerate(_linears(net)):
            linear.weight.copy_(torch.from_numpy(np.asarray(arrays[f"W{i}"], dtype=np.float32)))
            linear.bias.copy_(torch.from_numpy(np.asarray(arrays[f"b{i}"], dtype=np.float32)))


def fit(
    observations: np.ndarray,
    actions: np.ndarray,
    *,
    start: Mapping[str, np.ndarray] | None,
    scaling: tuple[np.ndarray, np.ndarray],
    hidden: Sequence[int],
    epochs: int,
    batch_size: int,
    learning_rate: float,
    seed: Sequence[int],
    loss: str = "mse",
    classes: int = 0,
    prior: np.ndarray | None = None,
) -> tuple[Arrays, float]:
    """Fit the MLP to (observation, normalised expert action) pairs by MSE; returns arrays and final loss.

    ``start`` (the previous round's arrays) warm-starts the fit; without it the layers are
    initialised from ``seed``. The minibatch order comes from ``seed`` too, so the same data,
    start and seed give the same weights (on one torch thread).

    DECISION (docs/rl.md §4.2): MSE on the action normalised to [-1, 1] by the action box, a
    fresh Adam at each refit, ``epochs`` passes over the whole aggregated data set (DAgger's
    "train on all data so far"), warm-started from the last round's network. ``loss="mse-std"``
    divides each channel's error by that channel's spread in the labels (the ``action_scale``
    saved with the arrays, frozen at round 0 as the observation scaling is), so the pitch
    channel, whose labels are 40 times narrower than the turn's, is not left to noise.

    ``classes`` > 0: ``actions`` are class indices (n,) and the network's ``classes`` outputs are
    logits fitted by cross-entropy (the ``turn`` head, docs/rl.md §4.8); ``loss`` is then unused.
    ``prior`` (n, classes), with ``classes``: a fixed score per class added to the logits with a
    learned weight exp(w) (the ``turn-value`` head, docs/rl.md §4.9; w starts at log 10, or at
    ``start["prior_log_weight"]``), saved as ``prior_log_weight``.
    """
    torch = _torch()
    generator = torch.Generator().manual_seed(int(np.random.SeedSequence(list(seed)).generate_state(1)[0]))
    torch.manual_seed(int(np.random.SeedSequence([*seed, 1]).generate_state(1)[0]))
    net = _build(torch, observations.shape[1], hidden, classes or actions.shape[1])
    if start is not None:
        _load_arrays(torch, net, start)
    mean, scale = scaling
    x = torch.from_numpy(((observations - mean) / scale).astype(np.float32))
    if classes:
        log_weight = None
        if prior is not None:
            initial = float(start["prior_log_weight"]) if start is not None and "prior_log_weight" in start else PRIOR_LOG_WEIGHT
            log_weight = torch.nn.Parameter(torch.tensor(initial, dtype=torch.float32))
        return _fit_classes(torch, net, x, torch.from_numpy(np.asarray(actions, dtype=np.int64)), generator,
                            epochs, batch_size, learning_rate, mean, scale,
                            None if prior is None else torch.from_numpy(np.asarray(prior, dtype=np.float32)),
                            log_weight)  # fmt: skip
    y = torch.from_numpy(np.asarray(actions, dtype=np.float32))
    if start is not None and "action_scale" in start:
        action_scale = np.asarray(start["action_scale"], dtype=np.float32)
    else:
        action_scale = action_spread(actions) if loss == "mse-std" else np.ones(actions.shape[1], np.float32)
    weight = torch.from_numpy(1.0 / action_scale**2)
    optimiser = torch.optim.Adam(net.parameters(), lr=learning_rate)
    loss = torch.zeros(())
    for _ in range(epochs):
        order = torch.randperm(len(x), generator=generator)
        for begin in range(0, len(x), batch_size):
            batch = order[begin : begin + batch_size]
            optimiser.zero_grad()
            loss = torch.mean(weight * (net(x[batch]) - y[batch]) ** 2)
            loss.backward()
            optimiser.step()
    with torch.no_grad():
        final = float(torch.mean(weight * (net(x) - y) ** 2))
    del loss
    return {**_to_arrays(net, mean, scale), "action_scale": action_scale}, final


def _fit_classes(
    torch: Any, net: Any, x: Any, y: Any, generator: Any, epochs: int, batch_size: int, learning_rate: float,
    mean: np.ndarray, scale: np.ndarray, prior: Any = None, log_weight: Any = None,
) -> tuple[Arrays, float]:
    """Cross-entropy on class indices ``y``, with the minibatches and Adam of the regression fit.

    With ``prior`` (n, classes) and ``log_weight`` (a scalar parameter): logits = net(x) + exp(w) * prior.
    """
    parameters = [*net.parameters(), *([log_weight] if log_weight is not None else [])]
    optimiser = torch.optim.Adam(parameters, lr=learning_rate)
    criterion = torch.nn.CrossEntropyLoss()

    def logits(rows: Any) -> Any:
        out = net(x[rows])
        return out if prior is None else out + torch.exp(log_weight) * prior[rows]

    everything = torch.arange(len(x))
    for _ in range(epochs):
        order = torch.randperm(len(x), generator=generator)
        for begin in range(0, len(x), batch_size):
            batch = order[begin : begin + batch_size]
            optimiser.zero_grad()
            criterion(logits(batch), y[batch]).backward()
            optimiser.step()
    with torch.no_grad():
        final = float(criterion(logits(everything), y))
    arrays = _to_arrays(net, mean, scale)
    if log_weight is not None:
        arrays["prior_log_weight"] = np.asarray(float(log_weight.detach()), dtype=np.float32)
    return arrays, final
