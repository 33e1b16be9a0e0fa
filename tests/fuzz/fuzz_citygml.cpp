// SPDX-License-Identifier: GPL-3.0-or-later
// libFuzzer target for the CityGML reader: any bytes must give a Status or a
// Scene, never a crash, a hang or a sanitizer report. Build with
// -DCITYATLAS_FUZZ=ON and clang (see tests/fuzz/README.md).
#include <cstdint>
#include <string>

#include "ingest/citygml/citygml_reader.h"
#include "tests/fuzz/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    // The reader streams from a file (twice), so the input goes to one, in
    // memory: rewritten on disk (/tmp) each run, ext4 flushed it on close and
    // the fuzzer spent three quarters of its time waiting (25 % of a core).
    static const std::string path = (cityatlas::fuzz::scratchDir("citygml") / "input.gml").string();
    if (!cityatlas::fuzz::writeFile(path, data, size)) return 0;
    cityatlas::SceneStatsSink sink;
    cityatlas::IngestState state;
    state.sink = &sink;
    state.options.fallback_crs = "EPSG:25832";  // reach the geometry code without an srsName
    (void)cityatlas::readCityGml(path, state);
    return 0;
}
