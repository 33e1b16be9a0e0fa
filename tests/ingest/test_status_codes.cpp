// SPDX-License-Identifier: GPL-3.0-or-later
// Failures carry a code callers branch on (cli/ picks the exit code from
// it): the readers' fatal classes map to the right one.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>

#include "ingest/citygml/citygml_reader.h"
#include "ingest/footprints/footprint_reader.h"
#include "ingest/scene_sink.h"
#include "ingest/synth/town.h"
#include "ingest/synth/write_town.h"
#include "test_support.h"

namespace cityatlas {
namespace {
namespace fs = std::filesystem;

Status readGml(const fs::path& f) {
    SceneStatsSink sink;
    IngestState state;
    state.sink = &sink;
    return readCityGml(f, state);
}

fs::path broken(const char* name) {
    const char* data = std::getenv("CITYATLAS_TEST_DATA");
    return fs::path(data ? data : "tests/data") / "citygml_broken" / name;
}

TEST(StatusCodes, NamesAreStable) {
    EXPECT_STREQ(statusCodeName(StatusCode::kOk), "ok");
    EXPECT_STREQ(statusCodeName(StatusCode::kUsage), "usage");
    EXPECT_STREQ(statusCodeName(StatusCode::kIo), "io");
    EXPECT_STREQ(statusCodeName(StatusCode::kInvalidInput), "invalid_input");
    EXPECT_STREQ(statusCodeName(StatusCode::kUnsupported), "unsupported");
    EXPECT_STREQ(statusCodeName(StatusCode::kInternal), "internal");
    const Status s = Status::Io("x.gml: cannot open").within("reading: ");
    EXPECT_EQ(s.code, StatusCode::kIo);
    EXPECT_EQ(s.error, "reading: x.gml: cannot open");
    EXPECT_TRUE(Status::Ok().within("ignored").ok());
}

TEST(StatusCodes, CityGmlFatalsAreInvalidInputAndAMissingFileIsIo) {
    for (const char* f : {"fatal_empty.gml", "fatal_png.gml", "fatal_svg_root.gml", "fatal_mismatched_tag.gml",
                          "fatal_xxe_file.gml", "fatal_crs_missing.gml", "fatal_crs_unknown_epsg.gml"}) {
        const Status s = readGml(broken(f));
        EXPECT_EQ(s.code, StatusCode::kInvalidInput) << f << ": " << s.error;
    }
    const Status missing = readGml(broken("does_not_exist.gml"));
    EXPECT_EQ(missing.code, StatusCode::kIo) << missing.error;
    EXPECT_TRUE(readGml(broken("valid_box.gml")).ok());
}

TEST(StatusCodes, AFootprintMappingToAMissingFieldIsAUsageError) {
    synth::TownSettings ts;
    ts.buildings = 2;
    ts.texture_size_px = 16;
    const fs::path dir = test::scratchPath("cityatlas_test_status", "town");
    ASSERT_TRUE(synth::writeTown(synth::generateTown(ts), dir, true, nullptr).ok());
    SceneStatsSink sink;
    IngestState state;
    state.sink = &sink;
    FootprintOptions o;
    o.fields["height"] = "no_such_field";
    const Status s = readFootprints(dir / "footprints.shp", o, state);
    EXPECT_EQ(s.code, StatusCode::kUsage) << s.error;
    EXPECT_EQ(s.error.rfind("usage: ", 0), std::string::npos) << "the code, not a prefix, says it: " << s.error;
}

}  // namespace
}  // namespace cityatlas
