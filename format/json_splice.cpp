// SPDX-License-Identifier: GPL-3.0-or-later
#include "format/json_splice.h"

namespace cityatlas::format {

std::string spliceArray(const std::string& text, int indent, const std::string& key, const std::string& placeholder,
                        size_t count, const std::function<std::string(size_t)>& element) {
    // Key and value with their quotes: inside a string value (a CRS name, a
    // path) the quotes would be escaped, so this is the member itself.
    const std::string member = '"' + key + "\": ";
    const size_t at = text.find(member + '"' + placeholder + '"');
    if (at == std::string::npos) return text;
    const size_t line = text.rfind('\n', at) + 1;  // npos + 1 = 0: the first line
    const size_t depth = at - line;
    std::string out;
    out.append(text, 0, at + member.size());
    if (count == 0) {
        out += "[]";
    } else {
        const std::string pad(depth + static_cast<size_t>(indent), ' ');
        out += "[\n";
        for (size_t i = 0; i < count; ++i) {
            out += pad;
            for (const char c : element(i)) {
                out += c;
                if (c == '\n') out += pad;
            }
            out += i + 1 < count ? ",\n" : "\n";
        }
        out.append(depth, ' ');
        out += ']';
    }
    out.append(text, at + member.size() + placeholder.size() + 2, std::string::npos);
    return out;
}

}  // namespace cityatlas::format
