// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// A JSON document with one very long array (a million texture entries) is
// dumped without holding that array as a DOM, whose nodes take ~10x its text:
// the document is dumped with a placeholder string in the array's place, and
// the array's text is written there, one element at a time.
#include <cstddef>
#include <functional>
#include <string>

namespace cityatlas::format {

/// `text`: a document dumped by nlohmann with `indent` spaces per level, in
/// which the member `"key": "placeholder"` appears once. Returns that text with
/// the member's value replaced by an array of `count` elements, element i
/// being `element(i)` (that element dumped on its own with the same indent):
/// the text a dump of the whole document would give. Returns `text` unchanged
/// when the member is not there.
std::string spliceArray(const std::string& text, int indent, const std::string& key, const std::string& placeholder,
                        size_t count, const std::function<std::string(size_t)>& element);

}  // namespace cityatlas::format
