// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// A JSON document with very long arrays (a million texture entries, a
// million dropped feature ids) is dumped without holding those arrays as a
// DOM, whose nodes take ~10x their text, or the document as one string: the
// document is dumped with placeholder strings in the arrays' places, and
// each array's text is written there, one element at a time, as the text
// goes out.
#include <cstddef>
#include <functional>
#include <ostream>
#include <string>
#include <vector>

namespace cityatlas::format {

/// One array to write in a placeholder's place.
struct SplicedArray {
    std::string placeholder;  ///< the string value standing for the array; unique in the text
    size_t count = 0;
    /// Element i, dumped on its own with the document's indent.
    std::function<std::string(size_t)> element;
};

/// `text`: a document dumped by nlohmann with `indent` spaces per level, in
/// which each `arrays[k].placeholder` (all starting with `prefix`, none
/// containing a quote) appears as a member's string value at most once, in
/// any order. Writes to `out` that text with each such value replaced by its
/// array: the text a dump of the whole document would give. A string value
/// starting with `prefix` that names no array is left as it is.
void spliceArrays(const std::string& text, int indent, const std::string& prefix,
                  const std::vector<SplicedArray>& arrays, std::ostream& out);

/// The same for one array, as a string (the member `"key": "placeholder"`).
std::string spliceArray(const std::string& text, int indent, const std::string& key, const std::string& placeholder,
                        size_t count, const std::function<std::string(size_t)>& element);

}  // namespace cityatlas::format
