"""Write the generated part of each env page, ``docs/envs/<id>.md``, and its rendered frame.

Each registered id's page opens with a block this script writes between two markers: a frame of
the env, then its specification (entry points, registered keyword arguments, ``max_episode_steps``,
the observation and action spaces as the env builds them, the normalised action space agents
train in (``baselines.zoo.NormalisedActions``), the reward and the episode end as the env
class's docstring states them, the render modes and the constructor's arguments with their
defaults and meanings). The prose around the block is written by hand; the block follows the code,
so a changed docstring, space or registration shows up as a stale page.

The frame is ``env.render()`` in ``rgb_array`` mode after the ``greedy`` floor has flown seed 0 to
the end of its episode, halved and saved as a palette PNG under ``docs/images/envs/<id>.png``.

Usage::

    python docs/hooks/env_pages.py            # rewrite the blocks and the frames
    python docs/hooks/env_pages.py --check    # exit 1 when a block is stale or a frame is missing
                                              # (the text only: rendering needs the compiled physics)
"""

from __future__ import annotations

import argparse
import inspect
import io
import re
import sys
from collections.abc import Sequence
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:  # run as a script from anywhere: this checkout's package
    sys.path.insert(0, str(ROOT))

START = "<!-- env-spec: written by docs/hooks/env_pages.py; edit the env's docstring instead -->"
END = "<!-- /env-spec -->"
LABELS = ("Observation", "Action", "Reward", "Episode end")
FRAME_SEED = 0
FRAME_SCALE = 2  # 640 x 640 frames shrink to 320 x 320


def rst_to_markdown(text: str) -> str:
    """A docstring's reST inline code (````x````) and cross-references as Markdown, on one line."""
    text = re.sub(r":\w+:`~?([^`]+)`", r"`\1`", " ".join(text.split()))
    return text.replace("``", "`")


def docstring_parts(cls: type) -> tuple[str, list[str], dict[str, str], dict[str, str]]:
    """The summary, unlabelled body paragraphs, labelled paragraphs and ``Args`` of ``cls``'s docstring.

    A labelled paragraph (``Reward: ...``) missing from ``cls`` is taken from the first base class
    that has it, as the behaviour is inherited.
    """
    summary, body, labelled, args = "", [], {}, {}
    for owner in cls.__mro__:
        doc = inspect.getdoc(owner) if owner.__doc__ else None
        if not doc:
            continue
        paragraphs = re.split(r"\n\s*\n", doc)
        own = owner is cls
        if own:
            summary = rst_to_markdown(paragraphs[0])
        for paragraph in paragraphs[1:]:
            head, _, rest = paragraph.partition(":")
            if head in LABELS:
                labelled.setdefault(head, rst_to_markdown(rest))
            elif own and head == "Args":
                args = parse_args(rest)
            elif own and not re.match(r"^[A-Z][\w ]*:\s*$", paragraph.splitlines()[0]):
                if "env pages' specification" not in paragraph:  # the note to the docstring's editors
                    body.append(rst_to_markdown(paragraph))
    return summary, body, labelled, args


def parse_args(section: str) -> dict[str, str]:
    """``{name: meaning}`` of a Google-style ``Args:`` section (continuation lines folded)."""
    args: dict[str, str] = {}
    name = None
    for line in section.strip("\n").splitlines():
        match = re.match(r"^\s{0,4}(\w+):\s*(.*)$", line)
        if match and not line.startswith(" " * 8):
            name = match[1]
            args[name] = match[2]
        elif name is not None:
            args[name] += " " + line.strip()
    return {k: rst_to_markdown(v) for k, v in args.items()}


def code(value: object) -> str:
    """``value`` as inline code, with table pipes escaped."""
    return "`" + str(value).replace("|", "\\|") + "`"


def spec_block(env_id: str) -> str:
    """The generated block of ``env_id``'s page (frame link, specification, arguments)."""
    import gymnasium as gym

    import uav_penetration_env  # noqa: F401  (registers the ids)

    spec = gym.spec(env_id)
    module, _, name = spec.entry_point.partition(":")
    cls = getattr(__import__(module, fromlist=[name]), name)
    summary, body, labelled, args = docstring_parts(cls)
    from baselines.zoo import NormalisedActions  # gymnasium and numpy only: no extra needed

    env = gym.make(env_id)
    try:
        observation_space = env.unwrapped.observation_space
        action_space = env.unwrapped.action_space
        normalised_space = NormalisedActions(env).action_space
    finally:
        env.close()
    kwargs = ", ".join(f"{k}={v!r}" for k, v in spec.kwargs.items())
    modes = ", ".join(code(m) for m in cls.metadata["render_modes"])
    vector_mode = "vector_entry_point" if spec.vector_entry_point else "sync"
    rows = [
        ("id", code(env_id)),
        ("make", f'`gym.make("{env_id}")` after `import uav_penetration_env`'),
        # An id without a native vector env is vectorised by Gymnasium's own wrappers.
        ("vector env", f'`gym.make_vec("{env_id}", num_envs=N, vectorization_mode="{vector_mode}")`'),
        ("entry point", f"{code(spec.entry_point)}: {summary}"),
        ("vector entry point", code(spec.vector_entry_point)),
        ("registered kwargs", code(kwargs) if kwargs else "none"),
        ("max_episode_steps", code(spec.max_episode_steps)),
        ("observation space", f"{code(observation_space)}: {labelled.get('Observation', '')}"),
        ("action space", f"{code(action_space)}: {labelled.get('Action', '')}"),
        (
            "normalised actions",
            f"`baselines.zoo.NormalisedActions(env)` gives {code(normalised_space)}: an action is clipped to "
            "[-1, 1] and mapped affinely onto the action space above, as "
            "`gymnasium.wrappers.RescaleAction(env, -1, 1)` maps it. Agents act in this space: "
            "`uav-bench train` (its SB3 adapter maps the same way) and rl-baselines3-zoo with the files "
            "`baselines/hyperparams/zoo/*.yml`, which name it as `env_wrapper` ([rl.md](../rl.md) §5)",
        ),
        ("reward", labelled.get("Reward", "")),
        ("episode end", labelled.get("Episode end", "")),
        ("render modes", f"{modes} at {cls.metadata['render_fps']} fps"),
    ]
    rows += [("scenarios", paragraph) for paragraph in body]
    lines = [
        START,
        "",
        f"![{env_id}: the greedy floor's track of seed {FRAME_SEED}, as env.render() draws it]"
        f"(../images/envs/{env_id}.png)",
        "",
        "## Specification",
        "",
        "Written from the registration, the spaces the env builds and the docstring of "
        f"`{name}` by `docs/hooks/env_pages.py` (`--check` compares).",
        "",
        "| | |",
        "|---|---|",
        *(f"| {key} | {value} |" for key, value in rows),
        "",
        "| argument | default | meaning |",
        "|---|---|---|",
    ]
    for parameter in list(inspect.signature(cls.__init__).parameters.values())[1:]:
        default = spec.kwargs.get(parameter.name, parameter.default)
        shown = "required" if default is inspect.Parameter.empty else code(repr(default))
        if parameter.name in spec.kwargs:
            shown += " (set by the id)"
        lines.append(f"| `{parameter.name}` | {shown} | {args.get(parameter.name, '')} |")
    return "\n".join([*lines, "", END])


def with_block(page: str, block: str, where: Path) -> str:
    """``page`` with the text between the markers replaced by ``block``."""
    start, end = page.find(START), page.find(END)
    if start < 0 or end < start:
        raise SystemExit(f"{where}: no {START!r} ... {END!r} block to write the specification into")
    return page[:start] + block + page[end + len(END) :]


def frame_png(env_id: str) -> bytes:
    """The page's frame: the greedy floor's episode of seed ``FRAME_SEED``, rendered, halved, in a palette."""
    import gymnasium as gym
    from PIL import Image

    from uav_penetration_env.benchmark.policies import GreedyPolicy

    env = gym.make(env_id, render_mode="rgb_array")
    try:
        observation, info = env.reset(seed=FRAME_SEED)
        policy = GreedyPolicy()
        policy.reset(env.unwrapped.model, FRAME_SEED)
        done = False
        while not done:
            observation, _, terminated, truncated, info = env.step(policy.act(observation, info))
            done = terminated or truncated
        frame = env.render()
    finally:
        env.close()
    image = Image.fromarray(frame)
    image = image.resize((image.width // FRAME_SCALE, image.height // FRAME_SCALE), Image.Resampling.LANCZOS)
    buffer = io.BytesIO()
    image.quantize(256, method=Image.Quantize.FASTOCTREE).save(buffer, format="PNG", optimize=True)
    return buffer.getvalue()


def main(argv: Sequence[str] | None = None) -> int:
    """Rewrite the env pages' blocks and frames, or ``--check`` them (exit 1 when stale)."""
    parser = argparse.ArgumentParser(
        prog="python docs/hooks/env_pages.py", description=__doc__.splitlines()[0]
    )
    parser.add_argument("--docs", type=Path, default=ROOT / "docs", help="the docs folder")
    parser.add_argument(
        "--check", action="store_true", help="compare instead of writing; exit 1 on a difference"
    )
    parser.add_argument("--ids", nargs="+", help="only these ids (default: every registered id)")
    args = parser.parse_args(argv)
    from uav_penetration_env import ENV_IDS
    from uav_penetration_env.atomic import atomic_open, write_text_atomic

    ids = args.ids or list(ENV_IDS)
    unknown = sorted(set(ids) - set(ENV_IDS))
    if unknown:
        raise SystemExit(f"--ids: got {unknown[0]!r}, expected one of {', '.join(ENV_IDS)}")
    stale: list[str] = []
    for env_id in ids:
        page_path = args.docs / "envs" / f"{env_id}.md"
        image_path = args.docs / "images" / "envs" / f"{env_id}.png"
        if not page_path.is_file():
            raise SystemExit(f"{page_path}: no page for the registered id {env_id}; write its prose first")
        page = page_path.read_text(encoding="utf-8")
        new = with_block(page, spec_block(env_id), page_path)
        if args.check:
            stale += [f"{page_path}: its specification is stale"] if new != page else []
            stale += [] if image_path.is_file() else [f"{image_path}: missing"]
            continue
        write_text_atomic(page_path, new)
        with atomic_open(image_path, "wb") as stream:
            stream.write(frame_png(env_id))
        print(f"wrote {page_path} and {image_path}")
    for problem in stale:
        print(f"{problem}; run python docs/hooks/env_pages.py", file=sys.stderr)
    return 1 if stale else 0


if __name__ == "__main__":
    raise SystemExit(main())
