// SPDX-License-Identifier: GPL-3.0-or-later
#include "ingest/diagnostics.h"

namespace cityatlas {

void Diagnostics::warn(const char* code, DiagnosticExample example) {
    Entry& e = entries_[code];
    e.count++;
    if (e.examples.size() < max_examples_) e.examples.push_back(std::move(example));
}

uint64_t Diagnostics::count(const std::string& code) const {
    auto it = entries_.find(code);
    return it == entries_.end() ? 0 : it->second.count;
}

uint64_t Diagnostics::total() const {
    uint64_t n = 0;
    for (const auto& [code, e] : entries_) n += e.count;
    return n;
}

}  // namespace cityatlas
