// SPDX-License-Identifier: GPL-3.0-or-later
#include "ingest/feature_spill.h"

#include <cstring>
#include <string>

#include <fmt/format.h>

namespace cityatlas {
namespace fs = std::filesystem;

namespace {

void putString(std::string& out, const std::string& s) {
    const auto n = static_cast<uint32_t>(s.size());
    out.append(reinterpret_cast<const char*>(&n), sizeof n);
    out.append(s);
}

template <typename T>
void putValue(std::string& out, T v) {
    out.append(reinterpret_cast<const char*>(&v), sizeof v);
}

// Reads what putString/putValue wrote; false at the end of the file or on a short read.
class Reader {
public:
    explicit Reader(std::ifstream& f) : f_(f) {}
    template <typename T>
    bool value(T* v) {
        return static_cast<bool>(f_.read(reinterpret_cast<char*>(v), sizeof *v));
    }
    bool string(std::string* s) {
        uint32_t n = 0;
        if (!value(&n)) return false;
        s->resize(n);
        return n == 0 || static_cast<bool>(f_.read(s->data(), n));
    }

private:
    std::ifstream& f_;
};

}  // namespace

FeatureSpill::FeatureSpill(fs::path path) : path_(std::move(path)), file_(path_, std::ios::binary) {}

uint32_t FeatureSpill::add(const Feature& f) {
    std::string rec;
    putString(rec, f.gml_id);
    putString(rec, f.name);
    putString(rec, f.source_file);
    putValue(rec, f.parent);
    putValue(rec, static_cast<uint8_t>(f.measured_height_m.has_value()));
    putValue(rec, f.measured_height_m.value_or(0.0));
    putString(rec, f.roof_type);
    putString(rec, f.function);
    putValue(rec, static_cast<uint32_t>(f.attributes.size()));
    for (const auto& [k, v] : f.attributes) putString(rec, k), putString(rec, v);
    file_.write(rec.data(), static_cast<std::streamsize>(rec.size()));
    lod_.push_back(f.lod);
    return static_cast<uint32_t>(lod_.size() - 1);
}

void FeatureSpill::setLod(uint32_t feature, int8_t lod) {
    if (feature < lod_.size()) lod_[feature] = lod;
}

Status FeatureSpill::finish() {
    file_.close();
    if (!file_) return Status::Io(fmt::format("{}: cannot write (disk full?)", path_.string()));
    return Status::Ok();
}

Status FeatureSpill::forEach(const std::function<Status(uint32_t id, Feature&& f)>& fn) const {
    std::ifstream f(path_, std::ios::binary);
    if (!f) return Status::Io(fmt::format("{}: cannot open", path_.string()));
    Reader in(f);
    for (uint32_t id = 0; id < lod_.size(); ++id) {
        Feature feature;
        uint8_t has_height = 0;
        double height = 0;
        uint32_t attributes = 0;
        bool ok = in.string(&feature.gml_id) && in.string(&feature.name) && in.string(&feature.source_file) &&
                  in.value(&feature.parent) && in.value(&has_height) && in.value(&height) &&
                  in.string(&feature.roof_type) && in.string(&feature.function) && in.value(&attributes);
        for (uint32_t a = 0; ok && a < attributes; ++a) {
            std::string k, v;
            ok = in.string(&k) && in.string(&v);
            if (ok) feature.attributes.emplace_hint(feature.attributes.end(), std::move(k), std::move(v));
        }
        if (!ok) return Status::Io(fmt::format("{}: feature {}: the file ends early", path_.string(), id));
        if (has_height) feature.measured_height_m = height;
        feature.lod = lod_[id];
        if (Status s = fn(id, std::move(feature)); !s.ok()) return s;
    }
    return Status::Ok();
}

Status FeatureSpill::readAll(std::vector<Feature>* out) const {
    out->clear();
    out->reserve(lod_.size());
    return forEach([&](uint32_t, Feature&& f) {
        out->push_back(std::move(f));
        return Status::Ok();
    });
}

}  // namespace cityatlas
