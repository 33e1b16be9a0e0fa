# Each footprint dataset in ../shared/data ingests; the report's counts of
# footprints read / repaired / skipped equal independent counts made with
# ogrinfo (SpatiaLite's ST_IsValid for invalid polygons, an SQL count for
# unusable heights); reports match their schema; the local frame is metric.
source "$(dirname "$0")/lib.sh" "$@"
DATA="$SRC/../shared/data"
if [ ! -d "$DATA" ]; then echo "SKIP: $DATA is absent (the team's shared data folder)"; exit 77; fi

sql() {  # sql FILE "SELECT COUNT(*) AS n ..." -> n
  ogrinfo -ro -q -dialect sqlite -sql "$2" "$1" | sed -n 's/^ *n (Integer) = //p'
}

# New York: heights in feet, WGS 84 lon/lat, one "ground" feature of height 0.
NYC="$DATA/shp_nyc_lower_manhattan_buildings/buildings.shp"
"$CITYATLAS" ingest "$NYC" --height-unit ft -q --report nyc.json > /dev/null || fail "NYC: ingest failed"
validate_json nyc.json "$SRC/schemas/ingest_report.schema.json"
check_eq "NYC footprints read" "$(sql "$NYC" "SELECT COUNT(*) AS n FROM buildings")" "$(json nyc.json "j['footprints']['read']")"
check_eq "NYC footprints repaired (ST_IsValid)" "$(sql "$NYC" "SELECT COUNT(*) AS n FROM buildings WHERE NOT ST_IsValid(geometry)")" \
  "$(json nyc.json "j['footprints']['repaired']")"
check_eq "NYC footprints skipped (height <= 0)" "$(sql "$NYC" "SELECT COUNT(*) AS n FROM buildings WHERE height <= 0")" \
  "$(json nyc.json "j['footprints']['skipped']")"
"$PY" -c "
import json,sys; j=json.load(open('nyc.json')); b=j['bbox_local']
dx, dy, dz = (b['max'][k]-b['min'][k] for k in range(3))
assert 500 < dx < 5000 and 500 < dy < 5000, (dx, dy)   # lower Manhattan in metres, not degrees
assert 300 < b['max'][2] < 600, b                      # the tallest tower in metres (1722 ft = 525 m)
print('ok: NYC local frame is metric:', round(dx), 'x', round(dy), 'm, top', round(b['max'][2]), 'm')" \
  || fail "NYC: local frame not metric or heights not converted from feet"

# Zug: WGS 84 / UTM 32S labels northern-hemisphere data (northings ~15.2e6 m).
for layer in zone surroundings; do
  Z="$DATA/shp_zug_cea_buildings/$layer.shp"
  "$CITYATLAS" ingest "$Z" -q --report "zug_$layer.json" > /dev/null || fail "Zug $layer: ingest failed"
  validate_json "zug_$layer.json" "$SRC/schemas/ingest_report.schema.json"
  check_eq "Zug $layer read" "$(sql "$Z" "SELECT COUNT(*) AS n FROM $layer")" "$(json "zug_$layer.json" "j['footprints']['read']")"
  check_eq "Zug $layer repaired" "$(sql "$Z" "SELECT COUNT(*) AS n FROM $layer WHERE NOT ST_IsValid(geometry)")" \
    "$(json "zug_$layer.json" "j['footprints']['repaired']")"
  check_eq "Zug $layer skipped (no positive height)" "$(sql "$Z" "SELECT COUNT(*) AS n FROM $layer WHERE height_ag <= 0")" \
    "$(json "zug_$layer.json" "j['footprints']['skipped']")"
  check_eq "Zug $layer CRS" "EPSG:32732" "$(json "zug_$layer.json" "j['georeference']['crs']")"
done
# Both Zug layers together: one frame, the first layer's.
"$CITYATLAS" ingest "$DATA/shp_zug_cea_buildings/zone.shp" "$DATA/shp_zug_cea_buildings/surroundings.shp" -q --report zug_both.json > /dev/null
check_eq "Zug both layers: features" "$(( $(json zug_zone.json "j['features']['total']") + $(json zug_surroundings.json "j['features']['total']") ))" \
  "$(json zug_both.json "j['features']['total']")"
check_eq "Zug both layers: one origin" "$(json zug_zone.json "j['georeference']['origin']")" "$(json zug_both.json "j['georeference']['origin']")"
# Georeference through PROJ: Zug's "UTM 32S" with +10,000 km northings is in
# Switzerland (47.17 N, 8.52 E); lower Manhattan is at 40.71 N, 74.01 W.
"$PY" -c "
import json
z = json.load(open('zug_zone.json'))['georeference']['origin_wgs84']
n = json.load(open('nyc.json'))['georeference']['origin_wgs84']
assert abs(z['lat_deg'] - 47.17) < 0.02 and abs(z['lon_deg'] - 8.51) < 0.02, z
assert abs(n['lat_deg'] - 40.71) < 0.03 and abs(n['lon_deg'] + 74.01) < 0.03, n
print('ok: Zug at', round(z['lat_deg'], 4), round(z['lon_deg'], 4), '- NYC at', round(n['lat_deg'], 4), round(n['lon_deg'], 4))" \
  || fail "origins are not where the datasets are"
