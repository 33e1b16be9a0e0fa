// SPDX-License-Identifier: GPL-3.0-or-later
#include "format/json_splice.h"

#include <sstream>
#include <string_view>
#include <unordered_map>

namespace cityatlas::format {

void spliceArrays(const std::string& text, int indent, const std::string& prefix,
                  const std::vector<SplicedArray>& arrays, std::ostream& out) {
    std::unordered_map<std::string_view, const SplicedArray*> by_name;
    for (const SplicedArray& a : arrays) by_name.emplace(a.placeholder, &a);
    // A member's string value starting with the prefix, quotes included:
    // inside a string value (a CRS name, a path) the quotes would be escaped.
    const std::string opening = "\": \"" + prefix;
    size_t from = 0;  // text written up to here
    for (size_t found = text.find(opening); found != std::string::npos; found = text.find(opening, found + 1)) {
        const size_t at = found + 3;  // the value's opening quote
        const size_t close = text.find('"', at + 1);
        if (close == std::string::npos) break;
        const auto it = by_name.find(std::string_view(text).substr(at + 1, close - at - 1));
        if (it == by_name.end()) continue;
        const SplicedArray& a = *it->second;
        const size_t line = text.rfind('\n', at);
        const size_t line_start = line == std::string::npos ? 0 : line + 1;
        // The member's indent: the spaces that start its line.
        size_t depth = 0;
        while (line_start + depth < at && text[line_start + depth] == ' ') ++depth;
        out.write(text.data() + from, static_cast<std::streamsize>(at - from));
        if (a.count == 0) {
            out << "[]";
        } else {
            const std::string pad(depth + static_cast<size_t>(indent), ' ');
            std::string chunk = "[\n";
            for (size_t i = 0; i < a.count; ++i) {
                chunk += pad;
                for (const char c : a.element(i)) {
                    chunk += c;
                    if (c == '\n') chunk += pad;
                }
                chunk += i + 1 < a.count ? ",\n" : "\n";
                if (chunk.size() > (size_t{1} << 16)) out << chunk, chunk.clear();
            }
            chunk.append(depth, ' ');
            chunk += ']';
            out << chunk;
        }
        from = close + 1;
    }
    out.write(text.data() + from, static_cast<std::streamsize>(text.size() - from));
}

std::string spliceArray(const std::string& text, int indent, const std::string& key, const std::string& placeholder,
                        size_t count, const std::function<std::string(size_t)>& element) {
    // Only a member named `key` holds the placeholder: the text before the value must be its key.
    const size_t at = text.find('"' + key + "\": \"" + placeholder + '"');
    if (at == std::string::npos) return text;
    std::ostringstream out;
    spliceArrays(text, indent, placeholder, {{placeholder, count, element}}, out);
    return out.str();
}

}  // namespace cityatlas::format
