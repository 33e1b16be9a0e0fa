// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The CityGML tests' one way of reading a file: the whole Scene in memory.

#include <filesystem>
#include <memory>

#include "ingest/citygml/citygml_reader.h"
#include "ingest/scene_sink.h"

namespace cityatlas::test {

/// One CityGML file read into a Scene in memory, with the reader's state.
struct Ingested {
    Status status;
    Scene scene;
    IngestState state;
};

inline std::unique_ptr<Ingested> ingest(const std::filesystem::path& file, CityGmlOptions options = {}) {
    auto r = std::make_unique<Ingested>();
    SceneCollector collector;
    r->state.options = options;
    r->state.sink = &collector;
    r->status = readCityGml(file, r->state);
    r->scene = std::move(collector.scene);
    return r;
}

}  // namespace cityatlas::test
