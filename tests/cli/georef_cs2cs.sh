# LocalToEcef (ingest/georef.h) against PROJ's command-line tool cs2cs
# (Debian proj-bin): each point goes source CRS -> LocalFrame -> local ->
# toEcef in tests/tools/georef_probe, and straight to EPSG:4978 in cs2cs. They
# must agree within 1 mm.
#
# Axis order. cs2cs takes EPSG codes in the axis order the EPSG definition
# declares: EPSG:4326, 6668 and 6697 are latitude, longitude; EPSG:31467
# (DHDN / 3-degree Gauss-Kruger zone 3) is northing, easting; the UTM codes are
# easting, northing. georef_probe, like LocalFrame, always takes x east-ish,
# y north-ish (easting northing, lon lat). So the cs2cs input below swaps the
# first two values for those CRSs. As a check that the swap is right, and not
# the same mistake made twice, EPSG:4326 is also compared with a +proj=longlat
# definition (lon, lat order in cs2cs), and a deliberately unswapped input must
# land kilometres away.
source "$(dirname "$0")/lib.sh" "$@"
PROBE="${GEOREF_PROBE:-}"
if [ -z "$PROBE" ] || [ ! -x "$PROBE" ]; then
  fail "GEOREF_PROBE must name the georef_probe executable (ctest sets it)"
fi
command -v cs2cs > /dev/null || { echo "SKIPPED: cs2cs is not installed (Debian: apt-get install proj-bin)"; exit 77; }
echo "cs2cs: $(cs2cs 2>&1 | head -1)"

oneline() { tr -s '\t ' '  ' <<< "$1"; }  # cs2cs separates with a tab and a space

# distance_mm "X Y Z" "X Y Z": prints the distance in mm; fails unless both are
# three finite numbers on the Earth's surface give or take 10 km.
distance_mm() {
  "$PY" - "$1" "$2" <<'PY'
import math, sys
a, b = (sys.argv[1].split(), sys.argv[2].split())
if len(a) != 3 or len(b) != 3: sys.exit(f"not three values: {a} {b}")
a, b = [float(v) for v in a], [float(v) for v in b]
for p in (a, b):
    r = math.hypot(*p)
    if not (math.isfinite(r) and 6.34e6 < r < 6.39e6): sys.exit(f"not an ECEF point on Earth: {p}")
print(f"{math.dist(a, b) * 1000:.3f}")
PY
}

# compare NAME SRS "X Y Z" "OX OY OZ" "CS2CS INPUT" [CS2CS CRS ARGS...]
# X Y Z and the origin in the probe's x east-ish order; the cs2cs input in the
# order the cs2cs CRS arguments (default: SRS EPSG:4978) expect.
compare() {
  local name="$1" srs="$2" point="$3" origin="$4" input="$5"; shift 5
  local crs_args=("$@")
  [ ${#crs_args[@]} -gt 0 ] || crs_args=("$srs" EPSG:4978)
  local ours theirs d
  # shellcheck disable=SC2086 # the coordinates are meant to split
  ours=$("$PROBE" "$srs" $point $origin) || fail "$name: georef_probe $srs $point $origin failed"
  theirs=$(echo "$input" | cs2cs -f %.4f "${crs_args[@]}") || fail "$name: cs2cs ${crs_args[*]} failed"
  d=$(distance_mm "$ours" "$theirs") || fail "$name: ours '$ours', cs2cs '$theirs'"
  "$PY" -c "import sys; sys.exit(0 if float(sys.argv[1]) <= 1.0 else 1)" "$d" ||
    fail "$name: ours ($ours) and cs2cs ($(oneline "$theirs")) differ by $d mm (> 1 mm)"
  echo "ok: $name: ours ($ours) cs2cs ($(oneline "$theirs")): $d mm"
}

# ETRS89 / UTM 33N, Berlin (STACK.md's probe point as the origin), 1 and 10 km away.
O="391779.259 5820072.159 34"
compare "25833 origin" EPSG:25833 "$O" "$O" "$O"
compare "25833 1 km" EPSG:25833 "392779.259 5820072.159 40" "$O" "392779.259 5820072.159 40"
compare "25833 10 km" EPSG:25833 "384708.191 5827143.227 120" "$O" "384708.191 5827143.227 120"

# WGS 84 / UTM 33S just south of the equator: northing 9.9e6, easting 833000
# (333 km east of the central meridian, the edge of the zone).
O="833000 9900000 0"
compare "32733 origin" EPSG:32733 "$O" "$O" "$O"
compare "32733 7 km" EPSG:32733 "828000 9905000 25" "$O" "828000 9905000 25"
compare "32733 12 km" EPSG:32733 "823000 9893000 12" "$O" "823000 9893000 12"

# WGS 84 / UTM 32N just north of the equator (northing ~1000 m), and a point
# south of the equator in the same north zone (negative northing).
O="640000 1000 5"
compare "32632 origin" EPSG:32632 "$O" "$O" "$O"
compare "32632 10 km" EPSG:32632 "647000 9000 20" "$O" "647000 9000 20"
compare "32632 negative northing" EPSG:32632 "633000 -4000 0" "$O" "633000 -4000 0"

# Geographic CRSs: an ENU frame. Probe: lon lat h; cs2cs with EPSG codes: lat lon h.
O="13.405 52.52 34"
compare "4326 origin" EPSG:4326 "$O" "$O" "52.52 13.405 34"
compare "4326 8 km" EPSG:4326 "13.5 52.45 60" "$O" "52.45 13.5 60"
compare "4326 8 km, +proj=longlat (lon lat order)" EPSG:4326 "13.5 52.45 60" "$O" "13.5 52.45 60" \
  +proj=longlat +datum=WGS84 +no_defs +type=crs +to EPSG:4978
# Negative control: lon, lat handed to cs2cs as they stand must be far off.
wrong=$(echo "13.5 52.45 60" | cs2cs -f %.4f EPSG:4326 EPSG:4978)
# shellcheck disable=SC2086 # the origin is meant to split
ours=$("$PROBE" EPSG:4326 13.5 52.45 60 $O)
"$PY" - "$ours" "$wrong" <<'PY' || fail "unswapped lon/lat must land far from ours, or the axis check proves nothing"
import math, sys
a, b = ([float(v) for v in x.split()] for x in sys.argv[1:3])
sys.exit(0 if math.dist(a, b) > 1e5 else 1)
PY
echo "ok: unswapped lon/lat input to cs2cs lands elsewhere ($(oneline "$wrong"))"

O="139.767 35.681 40"  # JGD2011 (Tokyo), 2D; and 6697 = JGD2011 + JGD2011 height (PLATEAU's CRS)
compare "6668 origin" EPSG:6668 "$O" "$O" "35.681 139.767 40"
compare "6668 7 km" EPSG:6668 "139.70 35.69 45" "$O" "35.69 139.70 45"
# No GSIGEO2011 grid in proj-data: both sides fall back to PROJ's ballpark
# vertical transformation (heights passed as ellipsoidal).
compare "6697 7 km (compound, no geoid grid)" EPSG:6697 "139.70 35.69 45" "$O" "35.69 139.70 45"

# DHDN / Gauss-Kruger zone 3: northing-first EPSG axis order, Bessel ellipsoid,
# a real datum shift (the BETA2007 grid proj-data bundles).
O="3500000 5500000 100"
compare "31467 origin" EPSG:31467 "$O" "$O" "5500000 3500000 100"
compare "31467 10 km" EPSG:31467 "3508000 5493000 150" "$O" "5493000 3508000 150"

echo "all cs2cs comparisons within 1 mm"
