// SPDX-License-Identifier: GPL-3.0-or-later
#include "format/json_splice.h"

#include <sstream>
#include <string_view>
#include <unordered_map>

namespace cityatlas::format {
namespace {

// `s` appended to `out` with `pad` spaces after each of its newlines.
void appendPadded(std::string& out, std::string_view s, size_t pad) {
    if (pad == 0) {
        out.append(s);
        return;
    }
    for (const char c : s) {
        out += c;
        if (c == '\n') out.append(pad, ' ');
    }
}

}  // namespace

void spliceArrays(const std::string& text, int indent, const std::string& prefix,
                  const std::vector<SplicedArray>& arrays, std::ostream& out, size_t pad) {
    std::unordered_map<std::string_view, const SplicedArray*> by_name;
    for (const SplicedArray& a : arrays) by_name.emplace(a.placeholder, &a);
    // Text goes out in chunks of about 64 KiB: an element's text is short.
    std::string chunk;
    const auto flush = [&] { out << chunk, chunk.clear(); };
    const auto emit = [&](std::string_view s, size_t p) {
        if (p == 0 && s.size() > (size_t{1} << 16)) {
            flush();
            out.write(s.data(), static_cast<std::streamsize>(s.size()));
            return;
        }
        appendPadded(chunk, s, p);
        if (chunk.size() > (size_t{1} << 16)) flush();
    };
    const auto element = [&](const SplicedArray& a, size_t i, size_t p) {
        if (!a.write) return emit(a.element(i), p);
        flush();
        a.write(i, p, out);
    };
    // A member's string value starting with the prefix, quotes included:
    // inside a string value (a CRS name, a path) the quotes would be escaped.
    const std::string opening = "\": \"" + prefix;
    const std::string_view all(text);
    size_t from = 0;  // text written up to here
    for (size_t found = text.find(opening); found != std::string::npos; found = text.find(opening, found + 1)) {
        const size_t at = found + 3;  // the value's opening quote
        const size_t close = text.find('"', at + 1);
        if (close == std::string::npos) break;
        const auto it = by_name.find(all.substr(at + 1, close - at - 1));
        if (it == by_name.end()) continue;
        const SplicedArray& a = *it->second;
        const size_t line = text.rfind('\n', at);
        const size_t line_start = line == std::string::npos ? 0 : line + 1;
        // The member's indent: the spaces that start its line (and the enclosing splice's).
        size_t depth = 0;
        while (line_start + depth < at && text[line_start + depth] == ' ') ++depth;
        depth += pad;
        emit(all.substr(from, at - from), pad);
        if (a.single) {
            element(a, 0, depth);
        } else if (a.count == 0) {
            emit("[]", 0);
        } else {
            const size_t inner = depth + static_cast<size_t>(indent);
            emit("[\n", 0);
            for (size_t i = 0; i < a.count; ++i) {
                chunk.append(inner, ' ');
                element(a, i, inner);
                emit(i + 1 < a.count ? ",\n" : "\n", 0);
            }
            chunk.append(depth, ' ');
            emit("]", 0);
        }
        from = close + 1;
    }
    emit(all.substr(from), pad);
    flush();
}

std::string spliceArray(const std::string& text, int indent, const std::string& key, const std::string& placeholder,
                        size_t count, const std::function<std::string(size_t)>& element) {
    // Only a member named `key` holds the placeholder: the text before the value must be its key.
    const size_t at = text.find('"' + key + "\": \"" + placeholder + '"');
    if (at == std::string::npos) return text;
    std::ostringstream out;
    spliceArrays(text, indent, placeholder, {{.placeholder = placeholder, .count = count, .element = element}}, out);
    return out.str();
}

}  // namespace cityatlas::format
