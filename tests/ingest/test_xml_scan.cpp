// SPDX-License-Identifier: GPL-3.0-or-later
// The CityGML index pass's SAX scan (ingest/citygml/xml_scan) and the texture
// header prefetch it feeds: the scan must see what the DOM reader sees
// (names, namespaces, lines, inherited srsDimension, decoded attributes),
// give captured subtrees whose namespaces resolve, and fail with the reader's
// one-line errors; a prefetched resolve must give the same textures and
// warnings as one without.
#include "ingest/citygml/xml_scan.h"

#include <gtest/gtest.h>

#include <OpenImageIO/imageio.h>

#include <fstream>
#include <map>
#include <random>
#include <vector>

#include "ingest/citygml/xml_input.h"
#include "ingest/scene_sink.h"
#include "ingest/texture_resolver.h"
#include "test_support.h"

namespace cityatlas::citygml {
namespace {
namespace fs = std::filesystem;

fs::path writeFile(const std::string& name, const std::string& body) {
    const fs::path p = test::scratchPath("xml_scan", name);
    std::ofstream(p, std::ios::binary) << body;
    return p;
}

struct Seen {
    int depth;
    std::string name, ns;
    int64_t line;
    int dimension;
    std::string id;
};

struct Recorder : ScanHandler {
    std::string root_name;
    std::vector<Seen> elements;
    std::vector<std::string> captured_report;
    std::vector<std::string> capture;  // local names to capture
    Status root_status;
    Status root(const ScanElement& e) override {
        root_name = e.local_name;
        return root_status;
    }
    bool element(const ScanElement& e) override {
        elements.push_back({e.depth, e.local_name, e.ns, e.line, e.srs_dimension,
                            e.attribute("id", "http://www.opengis.net/gml")});
        for (const std::string& c : capture)
            if (c == e.local_name) return true;
        return false;
    }
    bool captured(xmlNodePtr n, int depth, int dimension, int64_t line) override {
        xmlNodePtr inner = firstChild(n);
        captured_report.push_back(std::string(localName(n)) + " depth " + std::to_string(depth) + " dim " +
                                  std::to_string(dimension) + " line " + std::to_string(line) + " node line " +
                                  std::to_string(lineOf(n)) + " ns " + (n->ns ? (const char*)n->ns->href : "-") +
                                  " inner id " + (inner ? gmlId(inner) : "-") + " theme " +
                                  (inner && child(inner, "theme") ? text(child(inner, "theme")) : "-") + " href " +
                                  (inner && child(inner, "link") ? xlinkHref(child(inner, "link")) : "-"));
        return false;
    }
};

constexpr const char* kDoc = R"(<?xml version="1.0" encoding="UTF-8"?>
<core:CityModel xmlns:core="http://www.opengis.net/citygml/2.0" xmlns:gml="http://www.opengis.net/gml"
    xmlns:xlink="http://www.w3.org/1999/xlink" srsDimension="3">
  <core:cityObjectMember>
    <bldg:Building xmlns:bldg="http://www.opengis.net/citygml/building/2.0" gml:id="B&amp;1&lt;">
      <app:appearance xmlns:app="http://www.opengis.net/citygml/appearance/2.0">
        <app:Appearance gml:id="A1"><app:theme>rgb &amp; more</app:theme><app:link xlink:href="#x&amp;y"/></app:Appearance>
      </app:appearance>
      <gml:posList srsDimension="2">1 2 3 4</gml:posList>
      <gml:pos>5 6 7</gml:pos>
    </bldg:Building>
  </core:cityObjectMember>
</core:CityModel>
)";

TEST(XmlScan, SeesNamesLinesDimensionsAndDecodedAttributes) {
    Recorder r;
    r.capture = {"appearance"};
    uint64_t size = 0;
    const fs::path f = writeFile("doc.gml", kDoc);
    ASSERT_TRUE(scanXml(f, r, &size).ok());
    EXPECT_EQ(size, fs::file_size(f));
    EXPECT_EQ(r.root_name, "CityModel");
    ASSERT_EQ(r.elements.size(), 5u);  // member, Building, appearance, posList, pos (nothing inside the capture)
    EXPECT_EQ(r.elements[0].name, "cityObjectMember");
    EXPECT_EQ(r.elements[0].depth, 1);
    EXPECT_EQ(r.elements[1].name, "Building");
    EXPECT_EQ(r.elements[1].ns, "http://www.opengis.net/citygml/building/2.0");
    EXPECT_EQ(r.elements[1].id, "B&1<") << "&amp; and &lt; decoded as the DOM decodes them";
    EXPECT_EQ(r.elements[1].line, 5);
    EXPECT_EQ(r.elements[2].name, "appearance");
    EXPECT_EQ(r.elements[3].name, "posList");
    EXPECT_EQ(r.elements[3].dimension, 2) << "its own srsDimension";
    EXPECT_EQ(r.elements[4].name, "pos");
    EXPECT_EQ(r.elements[4].dimension, 3) << "the root's, inherited";
    EXPECT_EQ(r.elements[4].line, 10);
    ASSERT_EQ(r.captured_report.size(), 1u);
    EXPECT_EQ(r.captured_report[0],
              "appearance depth 3 dim 3 line 6 node line 6 ns http://www.opengis.net/citygml/appearance/2.0 inner id A1 "
              "theme rgb & more href x&y");
}

TEST(XmlScan, RootStatusEndsTheScan) {
    Recorder r;
    r.root_status = Status::Invalid("not_citygml: no");
    uint64_t size = 0;
    const Status s = scanXml(writeFile("root.gml", kDoc), r, &size);
    EXPECT_EQ(s.error, "not_citygml: no");
    EXPECT_TRUE(r.elements.empty());
}

// The DOM reader's walk over the same file, for its error.
std::string readerError(const fs::path& f) {
    XmlInput in;
    if (!in.open(f).ok()) return in.status().error;
    std::string name, ns;
    if (!in.rootElement(&name, &ns).ok()) return in.status().error;
    while (in.nextChild()) in.expand();
    return in.status().error;
}

TEST(XmlScan, FailsWithTheReadersErrors) {
    const std::string head = std::string(kDoc).substr(0, std::string(kDoc).find("  <core:cityObjectMember>"));
    struct Case {
        std::string name, body, code;
    } cases[] = {
        {"mismatched.gml", head + "  <core:cityObjectMember>\n    <a>\n    </b>\n  </core:cityObjectMember>\n</core:CityModel>\n",
         "xml_malformed"},
        {"truncated.gml", head + "  <core:cityObjectMember>\n    <gml:posList>1 2", "xml_malformed"},
        {"bad_char.gml", head + "  <core:cityObjectMember>\n    <a>\x01</a>\n  </core:cityObjectMember>\n</core:CityModel>\n",
         "xml_malformed"},
        {"empty.gml", "", "empty_file"},
        {"binary.gml", std::string("\x89PNG\r\n\x1a\n\0\0", 10), "not_xml"},
    };
    for (const Case& c : cases) {
        const fs::path f = writeFile(c.name, c.body);
        Recorder r;
        uint64_t size = 0;
        const Status s = scanXml(f, r, &size);
        EXPECT_EQ(s.error.rfind(c.code + ": " + f.string(), 0), 0u) << s.error;
        EXPECT_EQ(s.error, readerError(f)) << c.name;
    }
}

TEST(XmlScan, RefusesDoctypeBeforeAnyEntity) {
    const fs::path f = writeFile("doctype.gml", R"(<?xml version="1.0"?>
<!DOCTYPE lolz [<!ENTITY lol "lol"><!ENTITY lol2 "&lol;&lol;&lol;&lol;">]>
<core:CityModel xmlns:core="http://www.opengis.net/citygml/2.0">&lol2;</core:CityModel>
)");
    Recorder r;
    uint64_t size = 0;
    const Status s = scanXml(f, r, &size);
    EXPECT_EQ(s.error.rfind("doctype_forbidden: " + f.string() + ":", 0), 0u) << s.error;
    EXPECT_TRUE(r.root_name.empty()) << "stopped before the root";
}

TEST(XmlScan, UndeclaredPrefixIsReportedAndTheScanGoesOn) {
    // libxml2 reports an undeclared prefix as an error and reads on (the
    // element is in no namespace); the xmlTextReader walk stopped there
    // without a word, so a file with one such element read as a fraction
    // of itself, exit 0.
    const std::string head = std::string(kDoc).substr(0, std::string(kDoc).find("  <core:cityObjectMember>"));
    const fs::path f = writeFile("prefix.gml", head + "  <core:cityObjectMember>\n    <nope:Building/>\n"
                                                      "  </core:cityObjectMember>\n  <core:cityObjectMember/>\n"
                                                      "</core:CityModel>\n");
    struct NamespaceRecorder : Recorder {
        std::vector<std::pair<int64_t, std::string>> errors;
        void namespaceError(int64_t line, const std::string& message) override { errors.emplace_back(line, message); }
    } r;
    uint64_t size = 0;
    ASSERT_TRUE(scanXml(f, r, &size).ok());
    ASSERT_EQ(r.errors.size(), 1u);
    EXPECT_EQ(r.errors[0].first, 5);
    EXPECT_NE(r.errors[0].second.find("nope"), std::string::npos) << r.errors[0].second;
    ASSERT_EQ(r.elements.size(), 3u) << "the member after it is seen";
    EXPECT_EQ(r.elements[1].name, "Building");
    EXPECT_EQ(r.elements[1].ns, "");
    EXPECT_EQ(r.elements[2].name, "cityObjectMember");
    EXPECT_EQ(readerError(f), "") << "the read pass goes on too";
}

// --- texture header prefetch ---------------------------------------------------

void writePng(const fs::path& p, int w, int h, int channels) {
    auto out = OIIO::ImageOutput::create(p.string());
    ASSERT_TRUE(out);
    OIIO::ImageSpec spec(w, h, channels, OIIO::TypeDesc::UINT8);
    ASSERT_TRUE(out->open(p.string(), spec));
    std::vector<unsigned char> px(static_cast<size_t>(w) * h * channels, 128);
    ASSERT_TRUE(out->write_image(OIIO::TypeDesc::UINT8, px.data()));
    out->close();
}

TEST(TextureResolver, PrefetchGivesTheSameTexturesAndWarnings) {
    const fs::path dir = test::scratchPath("xml_scan", "images");
    fs::create_directories(dir);
    std::vector<std::string> uris;
    for (int i = 0; i < 40; ++i) {
        const std::string name = "img" + std::to_string(i) + ".png";
        if (i % 7 == 3) {
            std::ofstream(dir / name) << "not an image";
        } else if (i % 7 != 5) {  // i % 7 == 5: missing
            writePng(dir / name, 8 + i, 4 + i % 5, i % 2 ? 4 : 3);
        }
        uris.push_back(name);
    }
    uris.push_back("http://example.com/remote.png");
    uris.push_back("img1.png");  // again: cached

    auto run = [&](bool prefetch, size_t prefetch_count) {
        SceneCollector sink;
        Diagnostics diagnostics;
        std::vector<int32_t> indices;
        {
            TextureResolver resolver(sink, diagnostics);
            if (prefetch)
                for (size_t i = 0; i < prefetch_count && i < uris.size(); ++i) resolver.prefetch(dir, uris[i]);
            // Resolved in another order than prefetched: some are waited for, some read inline.
            for (size_t k = 0; k < uris.size(); ++k) {
                const size_t i = (k * 17) % uris.size();
                indices.push_back(resolver.resolve(dir, uris[i], WrapMode::None, {"f.gml", static_cast<int64_t>(i), "", ""}));
            }
        }
        std::string out;
        for (int32_t i : indices) out += std::to_string(i) + " ";
        for (size_t k = 0; k < sink.scene.textures.size(); ++k) {
            const TextureRef t = sink.scene.textures.ref(k);
            out += fs::path(t.path).filename().string() + ":" + std::to_string(t.width_px) + "x" +
                   std::to_string(t.height_px) + "x" + std::to_string(t.channels) + " ";
        }
        for (const auto& [code, entry] : diagnostics.entries()) {
            out += code + "=" + std::to_string(entry.count) + "[";
            for (const DiagnosticExample& e : entry.examples) out += std::to_string(e.line) + ",";
            out += "] ";
        }
        return out;
    };
    const std::string plain = run(false, 0);
    EXPECT_NE(plain.find("img8.png:16x7x3"), std::string::npos) << plain;
    EXPECT_NE(plain.find("texture_missing=6"), std::string::npos) << plain;   // 5 missing + the remote one
    EXPECT_NE(plain.find("texture_unreadable=6"), std::string::npos) << plain;
    EXPECT_EQ(run(true, uris.size()), plain);
    EXPECT_EQ(run(true, 10), plain) << "some prefetched, the rest read inline";
}

TEST(TextureResolver, ThousandsOfImagesAndWrapsKeepTheirFirstIndex) {
    // 3,600 images under 5 wrap modes: 18,000 textures, whose paths (~1.5
    // MB) pass the table's MiB in memory, so that most lookups compare a
    // path read back from its file; the resolver's table grows 9 times.
    const fs::path dir = test::scratchPath("xml_scan", "many_images");
    fs::create_directories(dir);
    constexpr int kImages = 3'600;
    const auto name = [](int image) { return "building_" + std::to_string(image) + "_facade_texture_of_the_wall.png"; };
    for (int i = 0; i < kImages; ++i) writePng(dir / name(i), 4, 4, 3);
    SceneCollector sink;
    Diagnostics diagnostics;
    TextureResolver resolver(sink, diagnostics);
    std::map<std::pair<int, int>, int32_t> first;  // (image, wrap) -> index
    std::mt19937 rng(9);
    const auto resolveOne = [&](int image, int wrap) {
        const int32_t got = resolver.resolve(dir, name(image), static_cast<WrapMode>(wrap), {"f.gml", image, "", ""});
        const auto [it, added] = first.emplace(std::pair{image, wrap}, got);
        if (added) {
            EXPECT_EQ(got, static_cast<int32_t>(first.size()) - 1) << "a new key is the next texture";
        } else {
            ASSERT_EQ(got, it->second) << image << " wrap " << wrap;
        }
    };
    for (int wrap = 0; wrap < 5; ++wrap)
        for (int image = 0; image < kImages; ++image) {
            resolveOne(image, wrap);
            if (image % 3 == 0) resolveOne(static_cast<int>(rng() % (image + 1)), static_cast<int>(rng() % (wrap + 1)));
        }
    for (int k = 0; k < 20'000; ++k) resolveOne(static_cast<int>(rng() % kImages), static_cast<int>(rng() % 5));
    ASSERT_EQ(sink.scene.textures.size(), size_t{5} * kImages);
    EXPECT_GT(sink.scene.textures.bytesOnDisk(), 0u) << "the case the test is for: paths read back";
    EXPECT_EQ(resolver.resolved(), 5u * kImages) << "distinct keys resolved";
    for (const auto& [key, index] : first) {
        ASSERT_EQ(fs::path(sink.scene.textures.path(static_cast<size_t>(index))).filename(), name(key.first));
        ASSERT_EQ(sink.scene.textures[static_cast<size_t>(index)].wrap, static_cast<WrapMode>(key.second));
    }
}

}  // namespace
}  // namespace cityatlas::citygml
