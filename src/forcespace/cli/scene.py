"""CLI command ``scene``: the bundled scenes and the scene schema, printed from the data.

    forcespace scene                 the bundled scenes and their descriptions
    forcespace scene NAME            a bundled scene's TOML (a start for your own)
    forcespace scene --schema [--json]   every key: type, default, range, unit, meaning
"""
from __future__ import annotations

from .printing import print_json
from ..errors import InputError


def register(sub) -> None:
    p = sub.add_parser("scene", help="list the bundled scenes, print one, or print the "
                       "scene schema (every key's type, default, range and meaning)")
    p.add_argument("name", nargs="?", default=None,
                   help="a bundled scene to print (e.g. paper); without it the scenes are listed")
    p.add_argument("--schema", action="store_true",
                   help="print every scene key with its type, default, allowed range, unit "
                        "and meaning (from forcespace.model.scene.SCHEMA)")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=cmd_scene)


def cmd_scene(args) -> int:
    from importlib.resources import files

    from ..model.scene import SCENES_PACKAGE, SCHEMA_VERSION, load_scene, schema_table, scenes

    if args.schema:
        if args.name:
            raise InputError("command line", "--schema", "takes no scene name")
        rows = schema_table()
        if args.json:
            print_json({"schema_version": SCHEMA_VERSION, "keys": rows})
            return 0
        print(f"# forcespace scene schema (version {SCHEMA_VERSION}); section.key = default"
              f"  [unit]  allowed: ...")
        section = None
        for row in rows:
            sec, name = row["key"].split(".")
            if sec != section:
                print(f"\n[{sec}]")
                section = sec
            unit = f"  [{row['unit']}]" if row["unit"] else ""
            default = f'"{row["default"]}"' if isinstance(row["default"], str) else \
                str(row["default"]).lower() if isinstance(row["default"], bool) else \
                row["default"]
            print(f"{name} = {default}{unit}  allowed: {row['allowed']}\n    {row['meaning']}")
        return 0
    bundled = scenes()
    if args.name is None:
        if args.json:
            print_json(bundled)
        else:
            for name, text in bundled.items():
                print(f"{name:12s} {text}")
        return 0
    if args.name not in bundled:
        raise InputError("command line", "scene", "must be a bundled scene: "
                         + ", ".join(bundled), got=args.name)
    text = (files(SCENES_PACKAGE) / f"{args.name}.toml").read_text(encoding="utf-8")
    if args.json:
        print_json(load_scene(args.name).values)
    else:
        print(text, end="" if text.endswith("\n") else "\n")
    return 0
