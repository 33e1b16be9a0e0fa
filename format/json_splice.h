// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// A JSON document with very long arrays (a million texture entries, a
// million dropped feature ids) or very many nested objects (a city's tiles)
// is dumped without holding those as a DOM, whose nodes take ~10x their
// text, or the document as one string: the document is dumped with
// placeholder strings in their places, and each one's text is written
// there, one element at a time, as the text goes out. An element may splice
// in turn (a tile's children), so only one path from the root to a leaf is
// ever held.
#include <cstddef>
#include <functional>
#include <ostream>
#include <string>
#include <vector>

namespace cityatlas::format {

/// One array (or one value) to write in a placeholder's place.
struct SplicedArray {
    std::string placeholder;  ///< the string value standing for the array; unique in the text
    size_t count = 0;
    /// Element i, dumped on its own with the document's indent.
    std::function<std::string(size_t)> element{};
    /// Instead of `element`: writes element i itself to the stream, every
    /// line after its first indented by `pad` more spaces (for an element
    /// that splices in turn: spliceArrays with that `pad`).
    std::function<void(size_t i, size_t pad, std::ostream& out)> write{};
    /// The placeholder stands for one value, element 0, not for an array.
    bool single = false;
};

/// `text`: a document dumped by nlohmann with `indent` spaces per level, in
/// which each `arrays[k].placeholder` (all starting with `prefix`, none
/// containing a quote) appears as a member's string value at most once, in
/// any order. Writes to `out` that text with each such value replaced by its
/// array: the text a dump of the whole document would give. A string value
/// starting with `prefix` that names no array is left as it is. `pad`: every
/// line of the text after its first gets that many more spaces (the text is
/// an element of an enclosing splice).
void spliceArrays(const std::string& text, int indent, const std::string& prefix,
                  const std::vector<SplicedArray>& arrays, std::ostream& out, size_t pad = 0);

/// The same for one array, as a string (the member `"key": "placeholder"`).
std::string spliceArray(const std::string& text, int indent, const std::string& key, const std::string& placeholder,
                        size_t count, const std::function<std::string(size_t)>& element);

}  // namespace cityatlas::format
