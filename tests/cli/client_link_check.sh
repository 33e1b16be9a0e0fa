# The client links none of the pipeline: cityatlas-client's direct shared
# libraries (readelf NEEDED) include none of GDAL, PROJ, CGAL/gmp/mpfr,
# libxml2, OpenImageIO, TBB; and its whole closure (ldd) none of GDAL, PROJ,
# libxml2, OpenImageIO, mpfr. (gmp may come in below libcurl: Debian's curl
# links GnuTLS through librtmp, and GnuTLS's nettle uses gmp; checked below
# that it is curl's and not ours.) The full `cityatlas` must fail the same
# check, or the check proves nothing.
source "$(dirname "$0")/lib.sh" "$@"
CLIENT="$(dirname "$CITYATLAS")/cityatlas-client"
[ -x "$CLIENT" ] || fail "no cityatlas-client beside $CITYATLAS"
command -v readelf > /dev/null || { echo "SKIPPED: readelf (binutils) is not installed"; exit 77; }
PIPELINE_LIBS='libgdal|libproj|libCGAL|libgmp|libmpfr|libxml2|libOpenImageIO|libtbb|libGeographic|libmeshoptimizer'
CLOSURE_LIBS='libgdal|libproj|libxml2|libOpenImageIO|libmpfr|libCGAL'

needed() { readelf -d "$1" | sed -n 's/.*Shared library: \[\(.*\)\]/\1/p'; }

needed "$CLIENT" > client.needed
if grep -E "$PIPELINE_LIBS" client.needed; then fail "cityatlas-client links pipeline libraries directly (above)"; fi
echo "ok: cityatlas-client needs $(wc -l < client.needed) libraries, none of the pipeline's: $(tr '\n' ' ' < client.needed)"

ldd "$CLIENT" > client.ldd
if grep -E "$CLOSURE_LIBS" client.ldd; then fail "cityatlas-client's closure holds pipeline libraries (above)"; fi
if grep -q libgmp client.ldd; then
  curl_lib=$(awk '/libcurl/ {print $3}' client.ldd)
  ldd "$curl_lib" > curl.ldd; grep -q libgmp curl.ldd || fail "libgmp is in cityatlas-client's closure and not through libcurl"
  echo "ok: libgmp only below libcurl ($curl_lib)"
fi
echo "ok: no pipeline library in cityatlas-client's closure ($(wc -l < client.ldd) libraries)"

# The check must be able to fail: the full command does link the pipeline.
needed "$CITYATLAS" > full.needed
grep -qE "libgdal" full.needed && grep -qE "libOpenImageIO" full.needed && grep -qE "libxml2" full.needed ||
  fail "the check cannot see the pipeline in the full cityatlas either: $(tr '\n' ' ' < full.needed)"
echo "ok: the full cityatlas does link them ($(grep -cE "$PIPELINE_LIBS" full.needed) of the listed libraries)"

# And the client works on its own: --help lists the client's commands only.
"$CLIENT" --help > help.txt
for c in render view serve; do grep -q "^  $c" help.txt || fail "cityatlas-client --help lacks $c"; done
if grep -qE "^  (build|synth|ingest|atlas|inspect)" help.txt; then fail "cityatlas-client offers pipeline commands"; fi
echo "ok: cityatlas-client offers render, view and serve"
