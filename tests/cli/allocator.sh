# Both executables run on mimalloc (CITYATLAS_MIMALLOC, the default): it is
# the first library the dynamic linker searches (first NEEDED entry), so its
# malloc is the one GDAL, libxml2, OIIO and our code call; and it is really
# loaded and initialised at run time (MIMALLOC_VERBOSE). Skipped when the
# build was configured without it.
source "$(dirname "$0")/lib.sh" "$@"
BUILD="$(cd "$(dirname "$CITYATLAS")/.." && pwd)"
if grep -q '^CITYATLAS_MIMALLOC:BOOL=OFF' "$BUILD/CMakeCache.txt" 2>/dev/null; then
  echo "SKIPPED: configured with -DCITYATLAS_MIMALLOC=OFF"; exit 77
fi
command -v readelf > /dev/null || { echo "SKIPPED: readelf (binutils) is not installed"; exit 77; }
for exe in "$CITYATLAS" "$(dirname "$CITYATLAS")/cityatlas-client"; do
  name=$(basename "$exe")
  first=$(readelf -d "$exe" | sed -n 's/.*Shared library: \[\(.*\)\]/\1/p' | head -1)
  case "$first" in libmimalloc.so*) echo "ok: $name's first library is $first" ;;
    *) fail "$name's first NEEDED library is '$first', not libmimalloc (glibc's malloc would serve the libraries)" ;; esac
  MIMALLOC_VERBOSE=1 "$exe" --version > version.txt 2> verbose.txt || fail "$name --version failed"
  grep -q '^mimalloc: process init' verbose.txt || { cat verbose.txt >&2; fail "$name did not initialise mimalloc"; }
  grep -q "cityatlas" version.txt || fail "$name --version printed $(cat version.txt)"
  echo "ok: $name initialises mimalloc at run time"
done
