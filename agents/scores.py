"""What an episode's score is on an env of this package: the value of its objective
(``ScenarioConfig.objective``), by name and unit, as the trainers log and print it."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

#: The score of each objective (``ScenarioConfig.objective``): its name (one node, several nodes;
#: also the key of the score in the envs' ``info`` at an episode's end) and its unit.
SCORES: dict[str, tuple[str, str, str]] = {
    "rate": ("average_rate", "min_rate", "bps/Hz"),
    "energy_efficiency": ("energy_efficiency", "energy_efficiency", "bits/J"),
}


@dataclass(frozen=True)
class ScoreLabel:
    """What an episode's score is on an env: the value of its objective, by name and unit."""

    objective: str  # ScenarioConfig.objective
    name: str  # "average_rate" (eq. (9)), "min_rate" (several nodes: max-min) or "energy_efficiency"
    unit: str  # "bps/Hz" or "bits/J"

    def text(self, value: float) -> str:
        """``value`` labelled, e.g. ``energy efficiency 4722 bits/J``."""
        return f"{self.name.replace('_', ' ')} {value:.6g} {self.unit}"


def score_label(env: Any) -> ScoreLabel:
    """The :class:`ScoreLabel` of a (single, possibly wrapped) env of this package: its objective
    (``env.unwrapped.config.objective``) and whether it serves several nodes (the node-block view of
    ``UAVEnv``: ``MultiNodeEnv``'s ids; the views ``"star_noma"`` and ``"miso_sdma"``: 2 to 4 users,
    whose ``min_rate`` is the episode's own max-min, ``score`` being ``score_plan``'s)."""
    base = env.unwrapped
    objective = base.config.objective
    if objective not in SCORES:
        raise ValueError(f"objective must be one of {', '.join(SCORES)}, got {objective!r}")
    one, several, unit = SCORES[objective]
    view = getattr(base, "view", None)
    return ScoreLabel(objective, several if view in ("node_blocks", "star_noma", "miso_sdma") else one, unit)
