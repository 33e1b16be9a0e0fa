// SPDX-License-Identifier: GPL-3.0-or-later
// libFuzzer target for the CityGML reader: any bytes must give a Status or a
// Scene, never a crash, a hang or a sanitizer report. Build with
// -DCITYATLAS_FUZZ=ON and clang (see tests/fuzz/README.md).
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>

#include "ingest/citygml/citygml_reader.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    // The reader streams from a file (twice), so the input goes to one.
    static const std::string path =
        (std::filesystem::temp_directory_path() / ("cityatlas_fuzz_" + std::to_string(getpid()) + ".gml")).string();
    std::FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) return 0;
    std::fwrite(data, 1, size, f);
    std::fclose(f);
    cityatlas::SceneStatsSink sink;
    cityatlas::IngestState state;
    state.sink = &sink;
    state.options.fallback_crs = "EPSG:25832";  // reach the geometry code without an srsName
    (void)cityatlas::readCityGml(path, state);
    return 0;
}
