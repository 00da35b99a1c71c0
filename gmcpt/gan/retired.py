"""Options that were measured and not adopted, which stored configs may still name.

Weights files and training checkpoints record the config they were made with,
including options since removed (docs/experiments.md keeps what they measured).
Reading such a config drops those keys where they hold the value the code now
always has, and refuses one that asks for the removed behaviour. The list is
data, ``retired.json`` beside this module: ``{section: {key: value}}``, with
``null`` for a key that mattered only beside another retired one (any value).
"""
from __future__ import annotations

import json
from pathlib import Path

#: section -> retired key -> the value that reads as today's behaviour (None: any)
RETIRED: dict[str, dict] = json.loads(Path(__file__).with_name("retired.json").read_text())


def drop_retired(section: str, data: dict) -> dict:
    """``data`` (one section of a config) without its retired keys.

    Raises
    ------
    ValueError
        When a retired key holds another value than the one that reads as today's behaviour.
    """
    kept = dict(data)
    for key, value in RETIRED.get(section, {}).items():
        if key not in kept:
            continue
        stored = kept.pop(key)
        if value is not None and json.loads(json.dumps(stored)) != value:  # tuples as lists, 0 as 0.0
            raise ValueError(f"{section}.{key} = {json.dumps(stored)} is a retired option (measured, not adopted: "
                             f"docs/experiments.md); only {json.dumps(value)} still reads")
    return kept
