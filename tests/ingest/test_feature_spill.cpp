// SPDX-License-Identifier: GPL-3.0-or-later
// Features through the build's spill file (ingest/feature_spill.h): every
// field comes back as given, LODs set after the feature was spilled are
// applied, and a cut file is an error naming the feature.
#include "ingest/feature_spill.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <limits>
#include <memory>
#include <string>

namespace cityatlas {
namespace {
namespace fs = std::filesystem;

bool same(const Feature& a, const Feature& b) {
    return a.gml_id == b.gml_id && a.name == b.name && a.source_file == b.source_file && a.parent == b.parent &&
           a.lod == b.lod && a.measured_height_m == b.measured_height_m && a.roof_type == b.roof_type &&
           a.function == b.function && a.attributes == b.attributes;
}

std::vector<Feature> sampleFeatures() {
    std::vector<Feature> v;
    Feature a;  // everything empty
    v.push_back(a);
    Feature b;
    b.gml_id = "bldg_000001";
    b.name = std::string("Zeche \xc3\x96stliche \0 mit NUL", 24);  // UTF-8 and an embedded NUL
    b.source_file = std::string(300, 'p') + "/town.gml";             // longer than any short-string buffer
    b.parent = 0;
    b.lod = 2;
    b.measured_height_m = -0.0;
    b.roof_type = "1040";
    b.function = "31001_1000";
    b.attributes = {{"storeysAboveGround", "2"}, {"", ""}, {"z", std::string(70000, 'x')}};
    v.push_back(b);
    Feature c;
    c.parent = std::numeric_limits<int32_t>::max();
    c.measured_height_m = 1e300;
    c.lod = 1;
    v.push_back(c);
    return v;
}

TEST(FeatureSpill, EveryFieldComesBackInIdOrderWithLaterLods) {
    const fs::path path = fs::path(::testing::TempDir()) / "features-roundtrip.spill";
    const std::vector<Feature> in = sampleFeatures();
    {
        FeatureSpill spill(path);
        for (size_t i = 0; i < in.size(); ++i) EXPECT_EQ(spill.add(in[i]), i);
        spill.setLod(0, 1);  // learned after the feature went to disk
        spill.setLod(99, 2);  // no such feature: ignored
        ASSERT_TRUE(spill.finish().ok());
        std::vector<Feature> out;
        ASSERT_TRUE(spill.readAll(&out).ok());
        ASSERT_EQ(out.size(), in.size());
        Feature first = in[0];
        first.lod = 1;
        EXPECT_TRUE(same(out[0], first));
        EXPECT_TRUE(same(out[1], in[1]));
        EXPECT_TRUE(same(out[2], in[2]));
        EXPECT_TRUE(std::signbit(*out[1].measured_height_m));
        EXPECT_FALSE(out[0].measured_height_m.has_value());
    }
    fs::remove(path);
}

// The sample features spilled to `name` in the test's temporary folder, finished.
std::unique_ptr<FeatureSpill> spilledSamples(const std::string& name) {
    auto spill = std::make_unique<FeatureSpill>(fs::path(::testing::TempDir()) / name);
    for (const Feature& f : sampleFeatures()) spill->add(f);
    EXPECT_TRUE(spill->finish().ok());
    return spill;
}

TEST(FeatureSpill, ACutFileIsAnErrorNamingTheFeature) {
    const auto spilled = spilledSamples("features-cut.spill");
    FeatureSpill& spill = *spilled;
    const fs::path path = spill.path();
    fs::resize_file(path, fs::file_size(path) - 10);  // the last feature loses its end
    uint32_t seen = 0;
    const Status s = spill.forEach([&](uint32_t, Feature&&) {
        ++seen;
        return Status::Ok();
    });
    EXPECT_FALSE(s.ok());
    EXPECT_NE(s.error.find("feature 2"), std::string::npos) << s.error;
    EXPECT_EQ(seen, 2u);
    fs::remove(path);
}

TEST(FeatureSpill, ACallbackErrorStopsTheWalk) {
    const auto spilled = spilledSamples("features-stop.spill");
    FeatureSpill& spill = *spilled;
    const fs::path path = spill.path();
    uint32_t seen = 0;
    const Status s = spill.forEach([&](uint32_t, Feature&&) { return ++seen == 2 ? Status::Io("stop") : Status::Ok(); });
    EXPECT_EQ(s.error, "stop");
    EXPECT_EQ(seen, 2u);
    fs::remove(path);
}

}  // namespace
}  // namespace cityatlas
