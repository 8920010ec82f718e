"""ODMD's generator configuration files (griffbr/ODMD, config/data_gen/*.yaml and
config/camera/*.yaml) as box generator settings, with the meaning the authors' generator
(odmd/data_gen/data_gen.py) gives them.

The authors' `DataGenerator` sets every key of its data file, then of its camera file, as an
attribute of one object, the later file's value replacing the earlier's; `read_box_config` reads
any number of files the same way, over a preset's settings when one is given. Each key is a
BoxParams field of the same name and meaning:

- `z_lim` [low, high]: the object's start depth, m, uniform;
- `move_min`, `move_max` [x, y, z]: the least and most movement along each axis, m, its sign
  drawn; `end_swap`: start and end swapped with probability 1/2;
- `size_lim` [low, high]: the object's width and height, m, each uniform;
- `num_pos`: positions (frames) per example;
- `perturb`: whether `std_dev` (box noise, a share of the image side), `shuffle` (the share of
  examples with one frame's box from another example) and `cam_dev` (movement noise, m) apply;
- the camera: `image_dim` [height, width] px, `fx`, `fy`, `cx`, `cy` px;
- `data_description` and `camera_name`: text, read and not used, as by the authors.

`rotation` (degrees the camera turns over an example, box_examples.py) is odms-data's addition.
A key the authors' generator derives from the others (`z_range`, `size_range`, the field of
view's margins) has no meaning of its own there, and any other key none: each is refused, in one
line naming the file and key, rather than ignored.

The files may come from a stranger: each is read no further than MAX_BYTES, its nesting is
counted from the parser's events before any value is built, and anchors, aliases and tags are
refused (the authors' files use none).
"""

from __future__ import annotations

import difflib
from dataclasses import asdict
from typing import Any

from ..errors import InputError
from ..extras import optional
from ..inputs import read_input
from .box_examples import BOX_PRESETS, BoxParams, box_setting_names, shown

MAX_BYTES = 64 * 2**10  # the authors' files are about 300 bytes
MAX_NESTING = 4  # a file is a mapping of scalars and lists of numbers: 2 levels
TEXT_KEYS = ("data_description", "camera_name")  # descriptions the authors' generator keeps, unused
AUTHORS_KEYS = tuple(k for k in box_setting_names() if k != "rotation")
DERIVED = {  # what the authors' generator computes from the settings, and from which
    "z_range": "z_lim", "move_range": "move_min and move_max", "size_range": "size_lim",
    "fx_norm": "fx and image_dim", "fy_norm": "fy and image_dim", "cx_norm": "cx and image_dim",
    "cy_norm": "cy and image_dim",
    **dict.fromkeys(("xmina", "xminb", "xmaxa", "xmaxb", "ymina", "yminb", "ymaxa", "ymaxb", "xa", "xb", "ya",
                     "yb"), "the camera, move_max and size_lim (the field of view's margins)"),
}


def read_box_config(paths: list[str], preset: str | None = None) -> BoxParams:
    """The box generator settings of ODMD configuration files `paths`, applied in order over
    preset `preset`'s settings, or, without one, giving every setting between them; InputError,
    naming the file and key, for a file that cannot be read or a key or value that the generator
    cannot honour."""
    if preset is not None and preset not in BOX_PRESETS:
        raise InputError(f"unknown box preset '{preset}'; the presets are {', '.join(BOX_PRESETS)}")
    settings: dict[str, Any] = asdict(BOX_PRESETS[preset]) if preset else {}
    origin = dict.fromkeys(settings, f"preset {preset}")
    for path in paths:
        for key, value in _read(path).items():
            _check_key(path, key)
            if key not in TEXT_KEYS:
                settings[key] = tuple(value) if isinstance(value, list) else value
                origin[key] = path
    missing = [k for k in AUTHORS_KEYS if k not in settings]
    if missing:
        raise InputError(f"{', '.join(paths)}: no {', '.join(missing)}; the authors' generator needs every "
                         "key of a config/data_gen file and of a config/camera file (give both files, "
                         "or a preset to start from: --boxes odmd --config FILE)")
    try:
        return BoxParams(**settings)
    except InputError as e:
        named = next((k for k in origin if str(e).startswith(f"{k} ")), None)
        where = origin[named] if named else ", ".join(paths)
        raise InputError(f"{where}: {e}") from None


def _check_key(path: str, key: object) -> None:
    if not isinstance(key, str):
        raise InputError(f"{path}: key {shown(key)} is not a setting's name")
    if key in DERIVED:
        raise InputError(f"{path}: {key} is not a setting: the authors' generator derives it from "
                         f"{DERIVED[key]}, which a config sets")
    if key not in (*box_setting_names(), *TEXT_KEYS):
        close = difflib.get_close_matches(key, box_setting_names(), n=1, cutoff=0.6)
        hint = f" (did you mean {close[0]}?)" if close else ""
        raise InputError(f"{path}: unknown key {shown(key)}{hint}; the box generator's keys are "
                         f"{', '.join((*AUTHORS_KEYS, *TEXT_KEYS))} (the authors') and rotation "
                         "(odms-data's)")


def _read(path: str) -> dict[Any, Any]:
    """The mapping of the YAML file at `path`, bounded before it is built."""
    yaml = optional("yaml", "odms-data generate --config")
    raw = read_input(path, "a generator config", MAX_BYTES)
    try:
        _check_events(path, yaml.parse(raw, Loader=yaml.SafeLoader), yaml)
        data = yaml.safe_load(raw)
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        at = f" at line {mark.line + 1}" if mark is not None else ""
        problem = getattr(e, "problem", None) or str(e).splitlines()[0]
        raise InputError(f"{path}: not valid YAML ({problem}{at})") from None
    if not isinstance(data, dict):
        raise InputError(f"{path}: expected a mapping of keys to values, as ODMD's config files are, "
                         f"got {type(data).__name__}")
    return data


def _check_events(path: str, events: Any, yaml: Any) -> None:
    """Refuse nesting deeper than MAX_NESTING, anchors, aliases and tags, from the parser's
    events (the parser keeps a list of states, not a recursion; building the values recurses)."""
    depth = 0
    for event in events:
        line = f" (line {event.start_mark.line + 1})" if event.start_mark else ""
        if isinstance(event, yaml.AliasEvent) or getattr(event, "anchor", None):
            raise InputError(f"{path}: anchors and aliases are not read in a generator config{line}")
        if getattr(event, "tag", None) is not None:
            raise InputError(f"{path}: tags are not read in a generator config{line}")
        if isinstance(event, yaml.CollectionStartEvent):
            depth += 1
            if depth > MAX_NESTING:
                raise InputError(f"{path}: nested deeper than {MAX_NESTING} levels{line}")
        elif isinstance(event, yaml.CollectionEndEvent):
            depth -= 1

