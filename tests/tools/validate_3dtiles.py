#!/usr/bin/env python3
"""Validates a 3D Tiles tileset.json against the official 3D Tiles 1.1 JSON
Schemas (tests/data/schemas/3d-tiles-1.1, draft 2020-12) with Debian's
python3-jsonschema, then checks what a schema cannot: every content uri is a
file inside the folder, the tree refines REPLACE with non-increasing
geometric errors, and only the root has a transform.

    validate_3dtiles.py TILESET.json [SCHEMA_DIR]

Prints one line per problem (JSON path: message) and a summary; exit 1 on any.
"""
import json
import pathlib
import sys

from jsonschema import Draft202012Validator


def validator_for(schema_dir):
    """A Draft 2020-12 validator whose relative $refs resolve inside schema_dir:
    with `referencing` (jsonschema >= 4.18), else with RefResolver (Debian 12's 4.10)."""
    schemas = {}
    for path in schema_dir.rglob("*.schema.json"):
        schemas[path.resolve().as_uri()] = json.loads(path.read_text())
    root_uri = (schema_dir / "tileset.schema.json").resolve().as_uri()
    root = schemas[root_uri]
    try:
        from referencing import Registry, Resource
        from referencing.jsonschema import DRAFT202012
        registry = Registry().with_resources(
            (uri, Resource.from_contents(s, default_specification=DRAFT202012)) for uri, s in schemas.items())
        return Draft202012Validator({"$ref": root_uri}, registry=registry)
    except ImportError:
        from jsonschema import RefResolver
        return Draft202012Validator(root, resolver=RefResolver(root_uri, root, store=schemas))


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    tileset_path = pathlib.Path(sys.argv[1])
    here = pathlib.Path(__file__).resolve().parent
    schema_dir = pathlib.Path(sys.argv[2]) if len(sys.argv) > 2 else here.parent / "data/schemas/3d-tiles-1.1"
    tileset = json.loads(tileset_path.read_text())
    validator = validator_for(schema_dir)
    problems = []
    for e in sorted(validator.iter_errors(tileset), key=lambda e: list(map(str, e.absolute_path))):
        problems.append("/" + "/".join(map(str, e.absolute_path)) + ": " + e.message[:300])

    folder = tileset_path.parent.resolve()
    tiles = contents = 0

    def walk(tile, pointer, parent_error):
        nonlocal tiles, contents
        tiles += 1
        if tile.get("refine", "REPLACE") != "REPLACE":
            problems.append(f"{pointer}/refine: {tile.get('refine')}, expected REPLACE")
        if parent_error is not None and tile["geometricError"] > parent_error:
            problems.append(f"{pointer}/geometricError: {tile['geometricError']} above its parent's {parent_error}")
        if pointer != "/root" and "transform" in tile:
            problems.append(f"{pointer}/transform: only the root carries one")
        if "contents" in tile:
            problems.append(f"{pointer}/contents: several contents per tile (3DTilesRendererJS renders none)")
        if "content" in tile:
            contents += 1
            uri = tile["content"].get("uri")
            target = (folder / uri).resolve() if isinstance(uri, str) else folder
            if folder not in target.parents or not target.is_file():
                problems.append(f"{pointer}/content/uri: {tile['content']['uri']} is not a file in the folder")
        for i, child in enumerate(tile.get("children", [])):
            walk(child, f"{pointer}/children/{i}", tile["geometricError"])

    if isinstance(tileset.get("root"), dict):
        walk(tileset["root"], "/root", tileset.get("geometricError"))
    for p in problems:
        print(f"{tileset_path}: {p}")
    print(f"{tileset_path}: {'INVALID' if problems else 'valid'} (3D Tiles 1.1 schemas; {tiles} tiles, "
          f"{contents} contents, {len(problems)} problems)")
    sys.exit(1 if problems else 0)


if __name__ == "__main__":
    main()
