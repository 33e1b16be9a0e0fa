// SPDX-License-Identifier: GPL-3.0-or-later
#include "ingest/citygml/xml_scan.h"

#include <libxml/SAX2.h>
#include <libxml/parser.h>

#include <cctype>
#include <cstdio>
#include <cstring>
#include <memory>
#include <vector>

#include <fmt/format.h>

#include "ingest/citygml/xml_input.h"
#include "ingest/diagnostics.h"

namespace cityatlas::citygml {
namespace {

// std::atoi of a value that is not NUL-terminated.
int atoi(std::string_view v) {
    char buf[64];
    if (v.size() >= sizeof buf) return std::atoi(std::string(v).c_str());
    v.copy(buf, v.size());
    buf[v.size()] = '\0';
    return std::atoi(buf);
}

bool startsWith(const xmlChar* s, const char* prefix) {
    return s && std::strncmp(reinterpret_cast<const char*>(s), prefix, std::strlen(prefix)) == 0;
}

struct ScanState {
    ScanHandler* handler = nullptr;
    std::string file;
    xmlParserCtxtPtr ctxt = nullptr;
    Status status;                       // the handler's or the DOCTYPE refusal
    std::string first_error;             // libxml2's first error
    int64_t first_error_line = 0;
    int depth = -1;                      // of the element being parsed
    int capture_depth = -1;              // of the captured subtree's root, -1 when none
    xmlNodePtr capture_root = nullptr;
    int capture_dimension = 0;
    int64_t capture_line = 0;
    // Namespace declarations in scope (prefix, URI) and where each depth's start.
    std::vector<const xmlChar*> scope;
    std::vector<size_t> scope_mark;
    std::vector<int> dimension;          // srsDimension in effect per depth

    void stop() { xmlStopParser(ctxt); }
};

ScanState& stateOf(void* ctx) { return *static_cast<ScanState*>(static_cast<xmlParserCtxtPtr>(ctx)->_private); }

int64_t currentLine(xmlParserCtxtPtr ctxt) { return ctxt->input ? ctxt->input->line : 0; }

void onStartDocument(void* ctx) { xmlSAX2StartDocument(ctx); }

void onStartElement(void* ctx, const xmlChar* local_name, const xmlChar* prefix, const xmlChar* uri, int ns_count,
                    const xmlChar** namespaces, int attribute_count, int defaulted, const xmlChar** attributes) {
    ScanState& st = stateOf(ctx);
    const int depth = ++st.depth;
    if (st.capture_depth >= 0) {
        xmlSAX2StartElementNs(ctx, local_name, prefix, uri, ns_count, namespaces, attribute_count, defaulted,
                              attributes);
        return;
    }
    st.scope_mark.push_back(st.scope.size());
    for (int i = 0; i < ns_count; ++i) {
        st.scope.push_back(namespaces[2 * i]);
        st.scope.push_back(namespaces[2 * i + 1]);
    }
    ScanElement e;
    e.depth = depth;
    e.local_name = reinterpret_cast<const char*>(local_name);
    e.ns = uri ? reinterpret_cast<const char*>(uri) : "";
    e.line = currentLine(st.ctxt);
    e.attribute_count = attribute_count;
    e.attributes = attributes;
    e.doc = st.ctxt->myDoc;
    std::string scratch;
    const std::string_view dim = e.attributeView("srsDimension", "", &scratch);
    e.srs_dimension = !dim.empty() ? atoi(dim) : st.dimension.empty() ? 0 : st.dimension.back();
    st.dimension.push_back(e.srs_dimension);

    if (depth == 0) {
        if (Status s = st.handler->root(e); !s.ok()) {
            st.status = s;
            st.stop();
        }
        return;
    }
    if (!st.handler->element(e)) return;
    // Capture: the subtree's root declares every namespace in scope (innermost
    // first wins), so names and attributes resolve as in the whole document.
    std::vector<const xmlChar*> in_scope;
    for (size_t i = st.scope.size(); i >= 2; i -= 2) {
        const xmlChar* p = st.scope[i - 2];
        bool seen = false;
        for (size_t k = 0; k < in_scope.size() && !seen; k += 2) seen = xmlStrEqual(in_scope[k], p) || (!p && !in_scope[k]);
        if (!seen) {
            in_scope.push_back(p);
            in_scope.push_back(st.scope[i - 1]);
        }
    }
    st.capture_depth = depth;
    st.capture_dimension = e.srs_dimension;
    st.capture_line = e.line;
    xmlSAX2StartElementNs(ctx, local_name, prefix, uri, static_cast<int>(in_scope.size() / 2), in_scope.data(),
                          attribute_count, defaulted, attributes);
    st.capture_root = st.ctxt->node;
}

void onEndElement(void* ctx, const xmlChar* local_name, const xmlChar* prefix, const xmlChar* uri) {
    ScanState& st = stateOf(ctx);
    const int depth = st.depth--;
    if (st.capture_depth >= 0) {
        xmlSAX2EndElementNs(ctx, local_name, prefix, uri);
        if (depth > st.capture_depth) return;
        xmlNodePtr root = st.capture_root;
        st.capture_depth = -1;
        st.capture_root = nullptr;
        if (root) {
            xmlUnlinkNode(root);
            if (!st.handler->captured(root, depth, st.capture_dimension, st.capture_line)) xmlFreeNode(root);
        }
    }
    st.scope.resize(st.scope_mark.back());
    st.scope_mark.pop_back();
    st.dimension.pop_back();
}

void onCharacters(void* ctx, const xmlChar* ch, int len) {
    if (stateOf(ctx).capture_depth >= 0) xmlSAX2Characters(ctx, ch, len);
}

void onReference(void* ctx, const xmlChar* name) {
    if (stateOf(ctx).capture_depth >= 0) xmlSAX2Reference(ctx, name);
}

void onDoctype(void* ctx, const xmlChar*, const xmlChar*, const xmlChar*) {
    ScanState& st = stateOf(ctx);
    if (st.status.ok())
        st.status = Status::Invalid(
            fmt::format("{}: {}:{}: {}", fatal::kDoctypeForbidden, st.file, currentLine(st.ctxt), kDoctypeRefused));
    st.stop();
}

void onError(void* ctx, xmlErrorPtr error) {
    if (!ctx || !static_cast<xmlParserCtxtPtr>(ctx)->_private) return;  // before the scan's state is attached
    ScanState& st = stateOf(ctx);
    if (!error || error->level < XML_ERR_ERROR || !st.first_error.empty()) return;
    std::string m = error->message ? error->message : "parse error";
    while (!m.empty() && std::isspace(static_cast<unsigned char>(m.back()))) m.pop_back();
    if (error->domain == XML_FROM_NAMESPACE) {  // libxml2 goes on; so do we
        st.handler->namespaceError(error->line, m);
        return;
    }
    st.first_error = m;
    st.first_error_line = error->line;
}

}  // namespace

std::string ScanElement::attribute(const char* name, const char* namespace_prefix) const {
    std::string scratch;
    const std::string_view v = attributeView(name, namespace_prefix, &scratch);
    return v.data() == scratch.data() ? std::move(scratch) : std::string(v);
}

std::string_view ScanElement::attributeView(const char* name, const char* namespace_prefix, std::string* scratch) const {
    for (int i = 0; i < attribute_count; ++i) {
        const xmlChar* const* a = attributes + 5 * i;
        if (std::strcmp(reinterpret_cast<const char*>(a[0]), name) != 0) continue;
        if (*namespace_prefix && !startsWith(a[2], namespace_prefix)) continue;
        // libxml2 hands '&' in attribute values to SAX as "&#38;" (its tree
        // builder decodes it); everything else arrives decoded.
        const std::string_view raw(reinterpret_cast<const char*>(a[3]), static_cast<size_t>(a[4] - a[3]));
        if (raw.find('&') == std::string_view::npos) return raw;
        std::string& v = *scratch;
        v.clear();
        v.reserve(raw.size());
        for (size_t k = 0; k < raw.size(); ++k) {
            v.push_back(raw[k]);
            if (raw[k] == '&' && raw.compare(k, 5, "&#38;") == 0) k += 4;
        }
        return v;
    }
    return {};
}

Status scanXml(const std::filesystem::path& file, ScanHandler& handler, uint64_t* file_size) {
    installXmlGuards();
    if (Status s = sniffXmlFile(file, file_size); !s.ok()) return s;
    std::unique_ptr<std::FILE, int (*)(std::FILE*)> f(std::fopen(file.string().c_str(), "rb"), &std::fclose);
    if (!f) return Status::Fail(StatusCode::kIo, fmt::format("{}: {}: cannot open for reading", fatal::kIoError, file.string()));

    xmlSAXHandler sax;
    std::memset(&sax, 0, sizeof sax);
    sax.initialized = XML_SAX2_MAGIC;
    sax.startDocument = onStartDocument;
    sax.startElementNs = onStartElement;
    sax.endElementNs = onEndElement;
    sax.characters = onCharacters;
    sax.ignorableWhitespace = onCharacters;
    sax.reference = onReference;
    sax.internalSubset = onDoctype;
    sax.serror = onError;

    ScanState st;
    st.handler = &handler;
    st.file = file.string();
    char head[4];
    const size_t head_n = std::fread(head, 1, sizeof head, f.get());
    st.ctxt = xmlCreatePushParserCtxt(&sax, nullptr, head, static_cast<int>(head_n), file.string().c_str());
    if (!st.ctxt) return Status::Fail(StatusCode::kIo, fmt::format("{}: {}: cannot open for reading", fatal::kIoError, file.string()));
    std::unique_ptr<xmlParserCtxt, void (*)(xmlParserCtxtPtr)> owner(st.ctxt, [](xmlParserCtxtPtr c) {
        if (c->myDoc) xmlFreeDoc(c->myDoc);
        c->myDoc = nullptr;
        xmlFreeParserCtxt(c);
    });
    // Declared after `owner`, so it runs while the parser (and its dictionary) still exists.
    struct EndOfScan {
        ScanHandler& handler;
        ~EndOfScan() { handler.endOfScan(); }
    } end_of_scan{handler};
    st.ctxt->_private = &st;
    xmlCtxtUseOptions(st.ctxt, kXmlParseOptions);
    st.ctxt->linenumbers = 1;

    std::vector<char> chunk(size_t{1} << 18);
    uint64_t done = head_n;
    bool more = true;
    while (more && st.status.ok() && st.first_error.empty()) {
        const size_t n = std::fread(chunk.data(), 1, chunk.size(), f.get());
        more = n == chunk.size();
        xmlParseChunk(st.ctxt, chunk.data(), static_cast<int>(n), more ? 0 : 1);
        done += n;
        handler.progress(done);
    }
    if (std::ferror(f.get()))
        return Status::Fail(StatusCode::kIo, fmt::format("{}: {}: {}", fatal::kIoError, file.string(), std::strerror(errno)));
    if (!st.status.ok()) return st.status;
    if (!st.first_error.empty() || !st.ctxt->wellFormed)
        return Status::Invalid(fmt::format("{}: {}:{}: {}", fatal::kXmlMalformed, file.string(),
                                           st.first_error_line > 0 ? st.first_error_line : currentLine(st.ctxt),
                                           st.first_error.empty() ? "malformed XML" : st.first_error));
    return Status::Ok();
}

}  // namespace cityatlas::citygml
