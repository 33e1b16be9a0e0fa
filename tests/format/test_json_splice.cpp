// SPDX-License-Identifier: GPL-3.0-or-later
// spliceArray(s) must give the text nlohmann's own dump of the whole document
// gives (the oracle), wherever the array sits and whatever the indent.
#include <gtest/gtest.h>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <sstream>
#include <utility>
#include <vector>

#include "format/json_splice.h"

namespace cityatlas::format {
namespace {
using nlohmann::json;
using nlohmann::ordered_json;

template <typename Json>
void expectSameAsWholeDump(const Json& elements, int indent) {
    const std::string placeholder = "splice-here";
    // Nested two deep, with members before and after it and a string value
    // that holds the member's text quoted (escaped in the dump: no match).
    Json doc = {{"a", 1}, {"outer", {{"z", "\"items\": \"splice-here\""}, {"items", placeholder}, {"after", {1, 2}}}}};
    Json whole = doc;
    whole["outer"]["items"] = elements;
    const std::string spliced = spliceArray(doc.dump(indent), indent, "items", placeholder, elements.size(),
                                            [&](size_t i) { return elements.at(i).dump(indent); });
    EXPECT_EQ(spliced, whole.dump(indent)) << "indent " << indent << ", " << elements.size() << " elements";
}

TEST(JsonSplice, GivesTheWholeDumpsTextForAnyIndentAndLength) {
    const json objects = json::array({{{"path", "a/b.png"}, {"bytes", 12}, {"xxh3", "00ff"}},
                                      {{"path", "c \"quoted\".png"}, {"bytes", 0}, {"xxh3", "1"}},
                                      {{"nested", {{"list", {1, 2, 3}}, {"empty", json::array()}}}}});
    for (int indent : {1, 2, 4})
        for (size_t n : {0u, 1u, 3u}) {
            json elements = json::array();
            for (size_t i = 0; i < n; ++i) elements.push_back(objects[i]);
            expectSameAsWholeDump(elements, indent);
            expectSameAsWholeDump(ordered_json(elements), indent);
        }
    expectSameAsWholeDump(json::array({1, "two", nullptr, 3.5}), 2);
}

// Several arrays at different depths, their placeholders in the text in
// another order than the list's, one placeholder-like value naming no
// array: the spliced stream is the whole dump (the oracle).
TEST(JsonSplice, SeveralArraysInAnyOrderGiveTheWholeDump) {
    for (int indent : {1, 3}) {
        json doc = {{"a", {{"deep", {{"x", "p-two"}}}}},
                    {"b", "p-one"},
                    {"c", {{"list", {"p-unknown", 2}}, {"y", "p-three"}}},
                    {"d", "\"y\": \"p-one\""}};
        const json one = json::array({1, 2, 3}), two = json::array({{{"k", {4, 5}}}, "s"}), three = json::array();
        json whole = doc;
        whole["b"] = one;
        whole["a"]["deep"]["x"] = two;
        whole["c"]["y"] = three;
        std::vector<SplicedArray> arrays;
        for (const auto& [name, value] : {std::pair{"p-three", &three}, std::pair{"p-one", &one}, std::pair{"p-two", &two}})
            arrays.push_back({.placeholder = name,
                              .count = value->size(),
                              .element = [value, indent](size_t i) { return value->at(i).dump(indent); }});
        std::ostringstream out;
        spliceArrays(doc.dump(indent), indent, "p-", arrays, out);
        EXPECT_EQ(out.str(), whole.dump(indent)) << "indent " << indent;
    }
}

// A tree written node by node (as tileset.json's tiles are): the root stands
// for one value, each node's children for an array whose elements splice in
// turn, at every depth's indent. The oracle: the dump of the whole tree.
json treeNode(int depth, int id) {
    json n = {{"id", id}, {"name", fmt::format("node \"{}\"", id)}, {"list", {id, id + 1}}};
    if (depth > 0) {
        n["children"] = json::array();
        for (int c = 0; c < 1 + id % 3; ++c) n["children"].push_back(treeNode(depth - 1, id * 4 + c + 1));
    }
    return n;
}

void writeNode(const json& whole, int indent, size_t pad, std::ostream& out) {
    json text = whole;
    std::vector<SplicedArray> arrays;
    if (whole.contains("children")) {
        const std::string placeholder = fmt::format("p-children-{}", whole.at("id").get<int>());
        text["children"] = placeholder;
        arrays.push_back({.placeholder = placeholder,
                          .count = whole.at("children").size(),
                          .write = [&whole, indent](size_t i, size_t p, std::ostream& o) {
                              writeNode(whole.at("children").at(i), indent, p, o);
                          }});
    }
    spliceArrays(text.dump(indent), indent, "p-", arrays, out, pad);
}

TEST(JsonSplice, ElementsThatSpliceInTurnGiveTheWholeDump) {
    for (int indent : {1, 2, 4})
        for (int depth : {0, 1, 3}) {
            const json tree = treeNode(depth, 1);
            const json whole = {{"asset", {{"version", "1.1"}}}, {"root", tree}, {"tail", {{"x", json::array()}}}};
            json doc = whole;
            doc["root"] = "p-root";
            std::ostringstream out;
            spliceArrays(doc.dump(indent), indent, "p-",
                         {{.placeholder = "p-root",
                           .count = 1,
                           .write = [&](size_t, size_t pad, std::ostream& o) { writeNode(tree, indent, pad, o); },
                           .single = true}},
                         out);
            EXPECT_EQ(out.str(), whole.dump(indent)) << "indent " << indent << ", depth " << depth;
        }
}

TEST(JsonSplice, LeavesATextWithoutThePlaceholderAlone) {
    const std::string text = json{{"items", "something else"}}.dump(2);
    EXPECT_EQ(spliceArray(text, 2, "items", "splice-here", 2, [](size_t) { return std::string("0"); }), text);
}

}  // namespace
}  // namespace cityatlas::format
