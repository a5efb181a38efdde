"""Checkpoint I/O: weights in safetensors, metadata in a JSON file beside them. No pickles.

A checkpoint named `stem` is the pair `stem.safetensors` + `stem.json`. Loading validates both and raises
CheckpointError naming the file and the problem (missing, truncated/corrupt, mismatched architecture).
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

import torch
from safetensors import SafetensorError
from safetensors.torch import load_file, save_file

ModelT = TypeVar("ModelT", bound=torch.nn.Module)


class CheckpointError(RuntimeError):
    """A checkpoint is missing, corrupt or does not match the model it is loaded into."""


def save_checkpoint(stem: str | Path, tensors: dict[str, torch.Tensor], metadata: dict) -> Path:
    """Write `stem.safetensors` and `stem.json` atomically (temp file + rename); returns the weights path."""
    stem = Path(stem)
    stem.parent.mkdir(parents=True, exist_ok=True)
    weights, meta = stem.with_suffix(".safetensors"), stem.with_suffix(".json")
    tmp_w, tmp_m = weights.with_suffix(".safetensors.tmp"), meta.with_suffix(".json.tmp")
    save_file({k: v.detach().contiguous().cpu() for k, v in tensors.items()}, str(tmp_w))
    tmp_m.write_text(json.dumps(metadata, indent=2, sort_keys=True) + "\n")
    for tmp in (tmp_w, tmp_m):
        tmp.chmod(0o644)
    tmp_w.replace(weights)
    tmp_m.replace(meta)
    return weights


def load_checkpoint(stem: str | Path) -> tuple[dict[str, torch.Tensor], dict]:
    """Read the tensors and metadata of `stem`; raises CheckpointError on any problem."""
    stem = Path(stem)
    try:
        if stem.suffix in (".safetensors", ".json"):
            stem = stem.with_suffix("")
        weights, meta = stem.with_suffix(".safetensors"), stem.with_suffix(".json")
    except ValueError as e:  # "." or "/": a path with no file name
        raise CheckpointError(f"checkpoint {str(stem)!r} names no file: {e}") from None
    for f in (weights, meta):
        if not f.is_file():
            raise CheckpointError(f"checkpoint file missing: {f}")
    try:
        metadata = json.loads(meta.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise CheckpointError(f"checkpoint metadata {meta} is not valid JSON: {e}") from e
    try:
        tensors = load_file(str(weights))
    except (SafetensorError, OSError, ValueError, RuntimeError) as e:
        raise CheckpointError(f"checkpoint weights {weights} are truncated or corrupt: {e}") from e
    return tensors, metadata


def load_state_into(module: torch.nn.Module, tensors: dict[str, torch.Tensor], source: str | Path) -> None:
    """Load tensors into `module` strictly; raises CheckpointError listing missing/unexpected/mismatched keys."""
    own = module.state_dict()
    missing = sorted(set(own) - set(tensors))
    unexpected = sorted(set(tensors) - set(own))
    mismatched = sorted(k for k in set(own) & set(tensors) if own[k].shape != tensors[k].shape)
    if missing or unexpected or mismatched:
        detail = "; ".join(
            f"{label}: {', '.join(keys[:5])}{' ...' if len(keys) > 5 else ''}"
            for label, keys in (("missing", missing), ("unexpected", unexpected), ("shape mismatch", mismatched))
            if keys
        )
        raise CheckpointError(f"checkpoint {source} does not match the model ({detail})")
    module.load_state_dict(tensors, strict=True)


def load_model(stem: str | Path, kind: str, what: str, build: Callable[[dict], ModelT]) -> tuple[ModelT, dict]:
    """Load checkpoint `stem` of metadata kind `kind` into `build(architecture)`, in eval mode; (model, metadata).

    what: the model's description in errors ("a robot-state VAE"). Raises CheckpointError naming the file and the
    problem: missing or unreadable files, another kind, a bad architecture entry, tensors that do not fit.
    """
    tensors, meta = load_checkpoint(stem)
    if meta.get("kind") != kind:
        raise CheckpointError(f"checkpoint {stem} is not {what} (kind={meta.get('kind')!r})")
    try:
        model = build(meta["architecture"])
    except (KeyError, TypeError, ValueError) as e:
        raise CheckpointError(f"checkpoint {stem} has a bad 'architecture' entry: {e}") from e
    load_state_into(model, tensors, stem)
    model.eval()
    return model, meta
