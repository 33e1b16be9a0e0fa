// SPDX-License-Identifier: GPL-3.0-or-later
// libFuzzer target for the footprint attribute mapping (ingest/footprints/
// footprint_reader): which attribute of a dataset holds what (explicit
// ROLE=FIELD mappings as `--map` gives them, else the common names looked up
// case-insensitively), and how the values are read (numbers in string or
// numeric fields, height units, storeys, roof types, textures, base heights).
// There is no separate mapping parser taking bytes, so the entry point is
// readFootprints on a GeoJSON dataset written to /dev/shm:
//
//   line 1      ROLE=FIELD;ROLE=FIELD;...  (the --map values; may be empty)
//   the rest    the dataset (GeoJSON)
//
// GDAL's built-in drivers open it as the CLI would (plugins are not loaded).
// Any input gives a Status or buildings, never a crash, a hang or a sanitizer
// report.
#include <algorithm>
#include <cstdint>
#include <string>

#include <cpl_conv.h>
#include <cpl_error.h>
#include <gdal_priv.h>

#include "ingest/footprints/footprint_reader.h"
#include "ingest/scene_sink.h"
#include "tests/fuzz/fuzz_support.h"

using namespace cityatlas;

namespace {

void quietGdal() {
    // Built-in drivers only: scanning for plugins on every GDALAllRegister
    // (readFootprints calls it per dataset) would be most of the time.
    CPLSetConfigOption("GDAL_DRIVER_PATH", "disable");
    GDALAllRegister();
    CPLSetErrorHandler(CPLQuietErrorHandler);
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
    quietGdal();
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    static const std::filesystem::path path = fuzz::scratchDir("footprints") / "footprints.geojson";
    const std::string input(reinterpret_cast<const char*>(data), size);
    const size_t eol = input.find('\n');
    const std::string maps = input.substr(0, eol == std::string::npos ? input.size() : eol);
    const std::string dataset = eol == std::string::npos ? std::string() : input.substr(eol + 1);

    FootprintOptions options;
    for (size_t at = 0; at <= maps.size();) {
        const size_t end = std::min(maps.find(';', at), maps.size());
        const std::string m = maps.substr(at, end - at);
        // As the CLI splits --map ROLE=FIELD (it refuses the rest before reading).
        if (const size_t eq = m.find('='); eq != std::string::npos && eq > 0 && eq + 1 < m.size())
            options.fields[m.substr(0, eq)] = m.substr(eq + 1);
        at = end + 1;
    }
    // A few option values from the input's length, so the unit and base paths run too.
    options.height_unit_m = size % 3 == 0 ? 0.3048 : 1.0;
    options.base = size % 4 == 1 ? FootprintOptions::Base::Field
                   : size % 4 == 2 ? FootprintOptions::Base::Constant
                                   : FootprintOptions::Base::Auto;
    options.base_constant_m = 12.5;
    if (!fuzz::writeFile(path, dataset.data(), dataset.size())) return 0;

    SceneStatsSink sink;
    IngestState state;
    state.sink = &sink;
    state.options.fallback_crs = "EPSG:25832";
    (void)readFootprints(path, options, state);
    return 0;
}
