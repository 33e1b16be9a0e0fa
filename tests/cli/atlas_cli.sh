# `cityatlas atlas` end to end on a synthetic town: the report matches its
# schema and the files on disk, its numbers agree with each other, with
# `cityatlas ingest` and with the formulas of atlas/atlas_tree.h; the output
# does not depend on --threads; bad options, missing inputs, existing output
# folders and corrupt textures get the documented exit codes and messages.
source "$(dirname "$0")/lib.sh" "$@"
SCHEMA="$SRC/schemas/atlas_report.schema.json"

no_partial() {
  local left
  left=$(find . -name '*.partial')
  [ -z "$left" ] || fail "$1 left a working folder behind: $left"
}

# Everything a tree folder must satisfy on its own. The PNGs are checked with a
# few lines of independent decoding (signature, chunk CRCs, IHDR, inflated
# size) rather than with OpenImageIO, the library that wrote them.
check_tree() {  # check_tree DIR
  validate_json "$1/atlas_report.json" "$SCHEMA"
  local pngs
  pngs=$(find "$1/atlas" -name '*.png' | wc -l)
  check_eq "$1: PNG files = tree.atlases" "$(json "$1/atlas_report.json" "j['tree']['atlases']")" "$pngs"
  "$PY" - "$1" <<'PY' || fail "$1: the tree is inconsistent"
import json, os, struct, sys, zlib
d = sys.argv[1]
r = json.load(open(os.path.join(d, "atlas_report.json")))
A = r["parameters"]["atlas_size_px"]
paths = [(name, l["atlas"], l["size"]) for n in r["nodes"] for name, l in n["layers"].items() if l["atlas"] is not None]
assert len(paths) == r["tree"]["atlases"], (len(paths), r["tree"]["atlases"])
on_disk = {os.path.relpath(os.path.join(root, f), d) for root, _, fs in os.walk(d) for f in fs}
assert on_disk == {"atlas_report.json"} | {p for _, p, _ in paths}, sorted(on_disk ^ ({"atlas_report.json"} | {p for _, p, _ in paths}))[:5]

def png_shape(path):
    b = open(path, "rb").read()
    assert b[:8] == b"\x89PNG\r\n\x1a\n", path
    pos, idat, ihdr, chunks = 8, b"", None, []
    while pos < len(b):
        n, kind = struct.unpack(">I4s", b[pos:pos + 8])
        data = b[pos + 8:pos + 8 + n]
        assert struct.unpack(">I", b[pos + 8 + n:pos + 12 + n])[0] == zlib.crc32(kind + data), (path, kind)
        chunks.append(kind)
        if kind == b"IHDR": ihdr = struct.unpack(">IIBBBBB", data)
        if kind == b"IDAT": idat += data
        pos += 12 + n
    assert chunks[0] == b"IHDR" and chunks[-1] == b"IEND", (path, chunks)
    w, h, depth, colour, _, _, interlace = ihdr
    channels = {2: 3, 6: 4}[colour]
    assert depth == 8 and interlace == 0, (path, ihdr)
    assert len(zlib.decompress(idat)) == h * (1 + w * channels), path
    return w, h, channels

for layer, p, size in paths:
    w, h, c = png_shape(os.path.join(d, p))
    assert [w, h] == size and w % 4 == 0 and h % 4 == 0 and w <= A and h <= A, (p, w, h, size)
    assert c == {"opaque": 3, "alpha": 4}[layer], (p, c)
print(f"ok: {d}: {len(paths)} atlases, PNGs of the sizes the report gives (at most {A} x {A}; RGB opaque, "
      "RGBA alpha), no other files")
PY
}

"$CITYATLAS" synth --buildings 60 --texture-size 128 -o town -q > /dev/null
"$CITYATLAS" atlas town/town.gml -o tree -q --d-min 150 > atlas.log || fail "atlas exited with $?"
no_partial "a successful run"
check_tree tree
# The schema is not vacuous: small breakages of a real report are rejected.
"$PY" - "$SCHEMA" <<'PY' || fail "the schema accepts broken reports"
import copy, json, jsonschema, sys
v = jsonschema.Draft202012Validator(json.load(open(sys.argv[1])))
r = json.load(open("tree/atlas_report.json"))
def rejects(change):
    x = copy.deepcopy(r)
    change(x)
    return not v.is_valid(x)
assert rejects(lambda x: x["nodes"][0]["children"].pop())
assert rejects(lambda x: x["nodes"][0].update(extra=1))
assert rejects(lambda x: x["nodes"][0]["layers"]["opaque"].update(atlas="atlas/alpha/0.png"))
assert rejects(lambda x: next(l for n in x["nodes"] for l in n["layers"].values() if "coverage" in l).pop("coverage"))
assert rejects(lambda x: x["tree"]["coverage"].update(overall=1.5))
assert rejects(lambda x: x["parameters"].update(atlas_size_px=100))
assert rejects(lambda x: x.pop("texels"))
print("ok: the schema rejects broken copies of the report")
PY
"$CITYATLAS" ingest town/town.gml --report ingest.json -q > /dev/null
check_eq "scene.triangles = ingest's triangles.total" "$(json ingest.json "j['triangles']['total']")" \
  "$(json tree/atlas_report.json "j['scene']['triangles']")"

# The report's numbers against each other and against atlas_tree.h's
# definitions; expected values come from those definitions and from the town
# (truth.json, the texture files), never from the report itself.
"$PY" - <<'PY' || fail "tree/atlas_report.json is inconsistent"
import glob, json, math, struct
r = json.load(open("tree/atlas_report.json"))
truth = json.load(open("town/truth.json"))
P, nodes, T = r["parameters"], r["nodes"], r["tree"]
A = P["atlas_size_px"]
close = lambda a, b: math.isclose(a, b, rel_tol=1e-9, abs_tol=1e-12)

assert T["nodes"] == len(nodes) and [n["id"] for n in nodes] == list(range(len(nodes)))
is_leaf = lambda n: n["children"] == [-1, -1, -1, -1]
assert T["leaves"] == sum(map(is_leaf, nodes)), T
assert T["depth"] == max(n["level"] for n in nodes), T
assert T["triangles"] == r["scene"]["triangles"] + r["critical_triangles"]["triangles_added"], T

root = nodes[0]
assert root["parent"] == -1 and root["level"] == 0, root
assert all(l["offset"] == [0, 0] for l in root["layers"].values() if l["atlas"]), root
L = root["layers"]
opaque, alpha = L.get("opaque", {"first": 0, "count": 0}), L.get("alpha", {"first": 0, "count": 0})
assert opaque["count"] + alpha["count"] == T["triangles"], (opaque, alpha, T)
assert opaque["first"] == 0 and (alpha["count"] == 0 or alpha["first"] == opaque["count"]), (opaque, alpha)
assert alpha["count"] > 0, "the town has RGBA textures, so an alpha layer"

d_used = r["d_min"]["used_m"]
seen_as_child = set()
for n in nodes:
    if is_leaf(n):
        assert n["min_distance_m"] == d_used and n["sharp_from_m"] >= d_used, n["id"]
        continue
    kids = [(q, c) for q, c in enumerate(n["children"]) if c >= 0]
    for q, c in kids:
        k = nodes[c]
        assert c > n["id"] and c not in seen_as_child, (n["id"], c)
        seen_as_child.add(c)
        assert k["parent"] == n["id"] and k["level"] == n["level"] + 1, (n["id"], c)
        for ax in range(3):
            assert n["bounds"]["min"][ax] <= k["bounds"]["min"][ax] and k["bounds"]["max"][ax] <= n["bounds"]["max"][ax]
    # atlas_tree.h: twice the largest child distance at which every child texel is at most a pixel.
    assert n["min_distance_m"] == 2 * max(nodes[c]["sharp_from_m"] for _, c in kids), n["id"]
    assert n["sharp_from_m"] == n["min_distance_m"], n["id"]
    # Each child's atlas, halved, lies inside this node's at offset(child) / 2 - offset(node), apart from its siblings'.
    for name, mine in n["layers"].items():
        if not mine["atlas"]: continue
        rects = []
        for _, c in kids:
            cl = nodes[c]["layers"].get(name)
            if not cl or not cl["atlas"]: continue
            assert cl["offset"][0] % 2 == 0 and cl["offset"][1] % 2 == 0, (c, cl["offset"])
            x, y = cl["offset"][0] // 2 - mine["offset"][0], cl["offset"][1] // 2 - mine["offset"][1]
            rect = (x, y, x + (cl["size"][0] + 1) // 2, y + (cl["size"][1] + 1) // 2)
            assert x >= 0 and y >= 0 and rect[2] <= mine["size"][0] and rect[3] <= mine["size"][1], (n["id"], c, rect, mine["size"])
            assert not any(rect[0] < o[2] and o[0] < rect[2] and rect[1] < o[3] and o[1] < rect[3] for o in rects), (n["id"], c)
            rects.append(rect)
    # Each layer's range is exactly its children's ranges laid end to end, and
    # its image exists exactly when one of theirs does (it is made of them).
    for name in ("opaque", "alpha"):
        parts = sorted((nodes[c]["layers"][name]["first"], nodes[c]["layers"][name]["count"])
                       for _, c in kids if name in nodes[c]["layers"])
        mine = n["layers"].get(name)
        if mine is None:
            assert not parts, (n["id"], name)
            continue
        at = mine["first"]
        for first, count in parts:
            assert first == at, (n["id"], name, parts, mine)
            at += count
        assert at == mine["first"] + mine["count"], (n["id"], name, parts, mine)
        has_child_atlas = any(nodes[c]["layers"].get(name, {}).get("atlas") for _, c in kids)
        assert (mine["atlas"] is not None) == has_child_atlas, (n["id"], name)
assert seen_as_child == set(range(1, len(nodes))), "every node but the root is exactly one node's child"

for n in nodes:
    for name, l in n["layers"].items():
        if l["atlas"] is not None:
            assert l["atlas"] == f"atlas/{name}/{n['id']}.png", l["atlas"]
        assert ("regions" in l) == (is_leaf(n) and l["atlas"] is not None), (n["id"], name)

# Regions are whole 4 x 4 blocks, so every leaf's packed area is a multiple of 16.
leaf_layers = [l for n in nodes if is_leaf(n) for l in n["layers"].values() if "coverage" in l]
areas = [l["coverage"] * l["size"][0] * l["size"][1] for l in leaf_layers]
assert all(abs(a - round(a)) < 1e-6 and round(a) % 16 == 0 and a > 0 for a in areas), areas[:5]
X, C = r["texels"], T["coverage"]
assert X["packed_texels"] == sum(round(a) for a in areas), X
assert X["leaf_atlas_texels"] == sum(l["size"][0] * l["size"][1] for l in leaf_layers), X
atlases = [(name, l["size"]) for n in nodes for name, l in n["layers"].items() if l["atlas"]]
assert X["atlas_texture_bytes"] == sum(w * h * {"opaque": 3, "alpha": 4}[name] for name, (w, h) in atlases), X
# The texel budget accounts for every atlas texel; the inner part is exactly the inner nodes' atlases.
B = X["budget"]
assert B["total"] == sum(w * h for _, (w, h) in atlases) == sum(v for k, v in B.items() if k != "total"), B
assert B["inner"] == sum(l["size"][0] * l["size"][1] for n in nodes if not is_leaf(n)
                         for l in n["layers"].values() if l["atlas"]), B
assert B["empty"] == X["leaf_atlas_texels"] - X["packed_texels"], B
# Bytes as BC with full mips and a DDS header, recomputed from the sizes.
def bc(w, h, ch):
    total = 128
    while True:
        total += ((w + 3) // 4) * ((h + 3) // 4) * (16 if ch == 4 else 8)
        if w == 1 and h == 1: return total
        w, h = max(1, w // 2), max(1, h // 2)
Y = r["bytes"]
assert Y["atlases"] == sum(bc(w, h, 4 if name == "alpha" else 3) for name, (w, h) in atlases), Y
assert close(C["overall"], X["packed_texels"] / X["leaf_atlas_texels"]), C
assert close(C["leaf_min"], min(l["coverage"] for l in leaf_layers)), C
assert close(C["leaf_mean"], sum(l["coverage"] for l in leaf_layers) / len(leaf_layers)), C

# Every texture of the town is used; bytes = width * height * channels from the PNG headers.
orig = 0
for f in glob.glob("town/textures/*.png"):
    w, h, _, colour = struct.unpack(">IIBB", open(f, "rb").read()[16:26])
    orig += w * h * {2: 3, 6: 4}[colour]
assert X["original_texture_bytes"] == orig, (X, orig)
orig_bc = 0
for f in glob.glob("town/textures/*.png"):
    w, h, _, colour = struct.unpack(">IIBB", open(f, "rb").read()[16:26])
    orig_bc += bc(w, h, {2: 3, 6: 4}[colour])
assert Y["originals_used"] == orig_bc and Y["originals_needed"] <= orig_bc, (Y, orig_bc)
assert close(Y["ratio"], (Y["atlases"] + Y["originals_needed"]) / orig_bc), Y
dm = r["d_min"]
assert dm["textures_exact"] + dm["textures_needing_originals"] == truth["textures"]["count"], dm
assert (Y["originals_needed"] == 0) == (dm["textures_needing_originals"] == 0), (Y, dm)
assert X["textures_unreadable"] == 0 and r["warnings"] == {} and r["warnings_total"] == 0, r["warnings"]
assert r["scene"]["textures"] == truth["textures"]["count"], r["scene"]

# The defaults --help announces (checked separately) are the ones used.
want = {"d_min_m": 150.0, "d_min_from_data": True, "atlas_size_px": 512, "border_px": 8, "screen_width_px": 1920, "screen_height_px": 1080,
        "vertical_fov_deg": 60.0, "filter": "lanczos3", "packing": "maxrects", "critical_fraction": 0.1,
        "threads": 0, "cache_mb": 256}
assert {k: P[k] for k in want} == want, P

f = (1080 / 2) / math.tan(math.radians(60) / 2)
cf = 1 + ((1920 / 2) ** 2 + (1080 / 2) ** 2) / f ** 2
pr, dm = r["projection"], r["d_min"]
assert close(pr["focal_px"], f) and close(pr["corner_factor"], cf), pr
assert close(pr["pixels_per_metre_at_d_min"], f * cf / dm["used_m"]), pr
assert dm["requested_m"] == 150 and dm["used_m"] >= 150 and dm["enlarged"] == (dm["used_m"] > 150), dm
ct = r["critical_triangles"]
assert ct["at_used_d_min"] <= ct["at_requested_d_min"] and ct["split"] == ct["at_used_d_min"], ct
assert (ct["triangles_added"] > 0) == (ct["split"] > 0), ct
print(f"ok: {len(nodes)} nodes, {T['leaves']} leaves, depth {T['depth']}: structure, ranges, offsets, distances, "
      "coverage, byte counts and projection agree")
PY

# The output must not depend on the thread count: same files, same report
# apart from timings and the threads parameter itself.
for t in 1 2; do
  "$CITYATLAS" atlas town/town.gml -o "threads$t" -q --d-min 300 --threads "$t" > /dev/null ||
    fail "--threads $t exited with $?"
  (cd "threads$t" && find . -type f ! -name atlas_report.json -print0 | sort -z | xargs -0 sha256sum) > "threads$t.sha"
  json "threads$t/atlas_report.json" \
    "[j.pop('steps'), j['parameters'].pop('threads'), json.dumps(j, indent=1)][-1]" > "threads$t.json"
done
[ "$(wc -l < threads1.sha)" -gt 10 ] || fail "--d-min 300 made too few files to compare"
cmp -s threads1.sha threads2.sha || { diff threads1.sha threads2.sha | head >&2 || true; fail "--threads 1 and 2 wrote different files"; }
cmp -s threads1.json threads2.json || { diff threads1.json threads2.json | head >&2 || true; fail "--threads 1 and 2 reports differ"; }
echo "ok: --threads 1 and --threads 2 give identical files ($(wc -l < threads1.sha)) and reports"

"$CITYATLAS" atlas --help > help.txt
for opt_default in "d-min auto" "atlas-size 512" "border 8" "screen 1920x1080" "fov 60" "filter lanczos3" \
                   "packing maxrects" "critical-percent 10" "threads 0" "cache-mb 256"; do
  read -r opt default <<< "$opt_default"
  grep -Eq -- "^ *--$opt [^ ]*.*=$default( |$)" help.txt || fail "atlas --help does not give --$opt with default $default"
done
echo "ok: --help lists the atlas options with their defaults"

expect_one_line() {  # as lib.sh's expect, and: one line on stderr, no output folder
  expect "$@"
  shift 3
  check_eq "'$*': stderr lines" 1 "$(wc -l < err.txt)"
  [ ! -e out ] || fail "'$*' created its output folder"
}
# validateParams names the parameter ("atlas size"), the CLI parser the option.
expect_one_line 2 "atlas[- ]size" -- atlas town/town.gml -o out -q --atlas-size 100
expect_one_line 2 "--d-min" -- atlas town/town.gml -o out -q --d-min -3
expect_one_line 2 "--filter.*bogus" -- atlas town/town.gml -o out -q --filter bogus
expect_one_line 1 "nothere\.gml" -- atlas nothere.gml -o out -q
no_partial "a rejected command"

mkdir keep && echo precious > keep/marker
expect_one_line 1 "keep.*already exists" -- atlas town/town.gml -o keep -q --d-min 600
check_eq "existing folder untouched" "precious" "$(cat keep/marker)"
check_eq "existing folder's files" "marker" "$(ls -A keep)"
"$CITYATLAS" atlas town/town.gml -o keep -q --d-min 600 --overwrite > /dev/null || fail "--overwrite exited with $?"
[ ! -e keep/marker ] || fail "--overwrite kept the old folder's files"
check_tree keep
no_partial "--overwrite"
echo "ok: --overwrite replaces the folder"

# Corrupt textures never stop the build. Garbage is caught when ingest opens
# the file (the texture is dropped, colour fallback); a truncated PNG whose
# header is intact only fails when the atlas stage decodes it (mid grey).
# Either way each one is reported exactly once.
corrupt_run() {  # corrupt_run NAME HOW: HOW = garbage | truncate
  rm -rf "$1"; cp -r town "$1"
  for i in 000007 000023; do
    local f="$1/textures/facade_$i.png"
    local orig="town/textures/facade_$i.png"
    if [ "$2" = garbage ]; then printf 'not a png %d\n' $(seq 300) > "$f"
    else head -c "$(($(stat -c %s "$orig") / 2))" "$orig" > "$f"; fi
  done
  local rc=0
  "$CITYATLAS" atlas "$1/town.gml" -o "$1.tree" -q --d-min 600 > /dev/null 2> "$1.err" || rc=$?
  [ $rc -eq 0 ] || { cat "$1.err" >&2; fail "atlas with $2 textures exited with $rc"; }
  check_tree "$1.tree"
}
corrupt_run garbage garbage
corrupt_run truncated truncate
"$PY" - <<'PY' || fail "corrupt textures are misreported"
import json
n = json.load(open("town/truth.json"))["textures"]["count"]
for name, dropped_at_ingest in (("garbage", 2), ("truncated", 0)):
    r = json.load(open(f"{name}.tree/atlas_report.json"))
    w = r["warnings"].get("texture_unreadable")
    assert w and w["count"] == 2, (name, r["warnings"])
    assert r["warnings_total"] == 2, (name, r["warnings"])
    files = sorted(e["detail"] + " " + e["file"] for e in w["examples"])
    assert all("facade_000007.png" in f or "facade_000023.png" in f for f in files), files
    assert r["scene"]["textures"] == n - dropped_at_ingest, (name, r["scene"])
    assert r["texels"]["textures_unreadable"] == 2 - dropped_at_ingest, (name, r["texels"])
    print(f"ok: {name} textures: exit 0, texture_unreadable = 2, {dropped_at_ingest} dropped at ingest, "
          f"texels.textures_unreadable = {2 - dropped_at_ingest}")
PY
no_partial "the whole test"

# peak_rss_mb is the process peak so far, so it cannot fall from one step to the next.
"$PY" - <<'PY' || fail "steps[].peak_rss_mb decreases: $(json tree/atlas_report.json "[(s['name'], s['peak_rss_mb']) for s in j['steps']]")"
import json
s = json.load(open("tree/atlas_report.json"))["steps"]
assert [x["name"] for x in s] == ["read", "estimate", "structure", "order", "images"], s
assert all(a["peak_rss_mb"] <= b["peak_rss_mb"] for a, b in zip(s, s[1:])), s
PY
echo "ok: steps in order, peak memory never decreases"
