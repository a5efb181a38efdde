"""A tabletop scene: obstacles in `world` above a table whose top is the plane z = 0."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

from latent_planner_ros.data.obstacles import Obstacle, obstacle_from_dict, obstacle_to_dict


@dataclass(frozen=True)
class Scene:
    """Obstacles of one scene.

    Attributes:
        obstacles: the obstacle primitives; a composite object is several entries.
        family: where the scene comes from ("train": boxes, cylinders, spheres, capsules, convex hulls;
            "heldout": non-convex composites; free text for hand-made scenes).
        seed: the seed the scene was generated from (-1 if unknown).
        groups: for each obstacle, the index of the object it is a part of (same length as obstacles).
    """

    obstacles: tuple[Obstacle, ...]
    family: str = "custom"
    seed: int = -1
    groups: tuple[int, ...] = field(default=())

    def __post_init__(self) -> None:
        if not self.groups:
            object.__setattr__(self, "groups", tuple(range(len(self.obstacles))))
        if len(self.groups) != len(self.obstacles):
            raise ValueError(f"groups has {len(self.groups)} entries for {len(self.obstacles)} obstacles")

    @property
    def n_objects(self) -> int:
        """Number of objects (composites count once)."""
        return len(set(self.groups))

    def to_dict(self) -> dict:
        return {
            "frame": "world",
            "family": self.family,
            "seed": self.seed,
            "groups": list(self.groups),
            "obstacles": [obstacle_to_dict(o) for o in self.obstacles],
        }

    @classmethod
    def from_dict(cls, d: dict) -> Scene:
        """Parse a scene dict; raises ValueError naming the problem (bad frame, bad obstacle index and field)."""
        if d.get("frame", "world") != "world":
            raise ValueError(f"scene frame must be 'world', got {d.get('frame')!r}")
        obstacles = []
        for i, o in enumerate(d.get("obstacles", [])):
            try:
                obstacles.append(obstacle_from_dict(o))
            except ValueError as e:
                raise ValueError(f"obstacle {i}: {e}") from e
        return cls(
            obstacles=tuple(obstacles),
            family=str(d.get("family", "custom")),
            seed=int(d.get("seed", -1)),
            groups=tuple(int(g) for g in d.get("groups", ())),
        )

    def to_json(self) -> str:
        return json.dumps(self.to_dict())

    @classmethod
    def from_json(cls, text: str) -> Scene:
        return cls.from_dict(json.loads(text))

    def save(self, path: str | Path) -> None:
        Path(path).write_text(self.to_json() + "\n")

    @classmethod
    def load(cls, path: str | Path) -> Scene:
        return cls.from_json(Path(path).read_text())
