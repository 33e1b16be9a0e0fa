// SPDX-License-Identifier: GPL-3.0-or-later
#include "ingest/citygml/xml_input.h"

#include <libxml/parser.h>
#include <libxml/xmlreader.h>

#include <cctype>
#include <cstdio>
#include <cstring>
#include <mutex>

#include <fmt/format.h>

#include "ingest/diagnostics.h"

namespace cityatlas::citygml {
namespace {

// Refuse every external resource, whatever the options say: a second guard
// behind XML_PARSE_NONET and the DOCTYPE rejection.
xmlParserInputPtr refuseExternalEntity(const char* url, const char*, xmlParserCtxtPtr ctxt) {
    if (ctxt) xmlCtxtReset(ctxt);
    std::fprintf(stderr, "cityatlas: refused to load external resource %s\n", url ? url : "(null)");
    return nullptr;
}

}  // namespace

void installXmlGuards() {
    static std::once_flag once;
    std::call_once(once, [] {
        xmlInitParser();
        xmlSetExternalEntityLoader(refuseExternalEntity);
    });
}

struct XmlInput::Impl {
    xmlTextReaderPtr reader = nullptr;
    std::string first_error;
    int64_t first_error_line = 0;
};

XmlInput::XmlInput() : impl_(new Impl) { installXmlGuards(); }

XmlInput::~XmlInput() {
    if (impl_->reader) xmlFreeTextReader(impl_->reader);
    delete impl_;
}

void XmlInput::fail(const char* code, int64_t line, const std::string& message) {
    if (!status_.ok()) return;
    const StatusCode kind = std::strcmp(code, fatal::kIoError) == 0 ? StatusCode::kIo : StatusCode::kInvalidInput;
    status_ = Status::Fail(kind, line > 0 ? fmt::format("{}: {}:{}: {}", code, file_.string(), line, message)
                                          : fmt::format("{}: {}: {}", code, file_.string(), message));
}

// libxml2's structured errors carry the line where the parser stood (for a
// mismatched end tag: that tag), not the line of the node being built.
static void collectError(void* arg, xmlErrorPtr error) {
    auto* impl = static_cast<XmlInput::Impl*>(arg);
    if (!error || error->level < XML_ERR_ERROR || !impl->first_error.empty()) return;
    // Namespace errors (an undeclared prefix) do not stop libxml2; the index
    // pass (xml_scan) has warned about each.
    if (error->domain == XML_FROM_NAMESPACE) return;
    std::string m = error->message ? error->message : "parse error";
    while (!m.empty() && std::isspace(static_cast<unsigned char>(m.back()))) m.pop_back();
    impl->first_error = m;
    impl->first_error_line = error->line;
}

Status sniffXmlFile(const std::filesystem::path& file, uint64_t* file_size) {
    auto fail = [&](const char* code, const std::string& message) {
        return Status::Fail(std::strcmp(code, fatal::kIoError) == 0 ? StatusCode::kIo : StatusCode::kInvalidInput,
                            fmt::format("{}: {}: {}", code, file.string(), message));
    };
    std::FILE* f = std::fopen(file.string().c_str(), "rb");
    if (!f) return fail(fatal::kIoError, std::strerror(errno));
    // Sniff the start: empty, whitespace only, or not XML at all (binary,
    // plain text) get their own clear message instead of a parser's.
    unsigned char head[512];
    const size_t n = std::fread(head, 1, sizeof head, f);
    std::fseek(f, 0, SEEK_END);
    *file_size = static_cast<uint64_t>(std::ftell(f));
    std::fclose(f);
    if (*file_size == 0) return fail(fatal::kEmptyFile, "the file is empty");
    size_t i = 0;
    if (n >= 3 && head[0] == 0xEF && head[1] == 0xBB && head[2] == 0xBF) i = 3;  // UTF-8 BOM
    while (i < n && std::isspace(head[i])) ++i;
    if (i == n && *file_size == n) return fail(fatal::kEmptyFile, "the file holds only whitespace");
    const bool utf16 = n >= 2 && ((head[0] == 0xFF && head[1] == 0xFE) || (head[0] == 0xFE && head[1] == 0xFF));
    if (!utf16 && (i >= n || head[i] != '<')) {
        bool binary = false;
        for (size_t k = 0; k < n; ++k) binary |= head[k] == 0;
        return fail(fatal::kNotXml, binary ? "binary data, not an XML (CityGML) file" : "text that is not XML (CityGML)");
    }
    return Status::Ok();
}

Status XmlInput::open(const std::filesystem::path& file) {
    file_ = file;
    if (Status s = sniffXmlFile(file, &file_size_); !s.ok()) {
        status_ = s;
        return status_;
    }
    impl_->reader = xmlReaderForFile(file.string().c_str(), nullptr, kXmlParseOptions);
    if (!impl_->reader) {
        fail(fatal::kIoError, 0, "cannot open for reading");
        return status_;
    }
    xmlTextReaderSetStructuredErrorHandler(impl_->reader, collectError, impl_);
    return status_;
}

bool XmlInput::readNode() {
    const int r = xmlTextReaderRead(impl_->reader);
    if (r == 1) {
        if (xmlTextReaderNodeType(impl_->reader) == XML_READER_TYPE_DOCUMENT_TYPE) {
            fail(fatal::kDoctypeForbidden, xmlTextReaderGetParserLineNumber(impl_->reader), kDoctypeRefused);
            return false;
        }
        return true;
    }
    if (r < 0 || !impl_->first_error.empty()) {
        const std::string msg = impl_->first_error.empty() ? "malformed XML" : impl_->first_error;
        const int64_t line = impl_->first_error_line > 0 ? impl_->first_error_line
                                                          : xmlTextReaderGetParserLineNumber(impl_->reader);
        fail(fatal::kXmlMalformed, line, msg);
    }
    return false;
}

Status XmlInput::rootElement(std::string* local_name, std::string* namespace_uri) {
    while (status_.ok() && readNode()) {
        if (xmlTextReaderNodeType(impl_->reader) == XML_READER_TYPE_ELEMENT) {
            *local_name = currentLocalName();
            *namespace_uri = currentNamespace();
            return status_;
        }
    }
    if (status_.ok()) fail(fatal::kXmlMalformed, 0, "no root element");
    return status_;
}

bool XmlInput::nextChild() {
    if (!status_.ok()) return false;
    // From the root element (depth 0) or a child (depth 1) to the next
    // element at depth 1; skipping a child's subtree frees it.
    if (at_child_) {
        const int r = xmlTextReaderNext(impl_->reader);
        if (r != 1) {
            if (r < 0 || !impl_->first_error.empty()) readNode();
            return false;
        }
        if (!impl_->first_error.empty()) {
            readNode();
            return false;
        }
        if (xmlTextReaderDepth(impl_->reader) == 1 && xmlTextReaderNodeType(impl_->reader) == XML_READER_TYPE_ELEMENT)
            return true;
    }
    while (readNode()) {
        const int depth = xmlTextReaderDepth(impl_->reader);
        const int type = xmlTextReaderNodeType(impl_->reader);
        if (depth == 1 && type == XML_READER_TYPE_ELEMENT) {
            at_child_ = true;
            return true;
        }
        if (depth == 0 && type == XML_READER_TYPE_END_ELEMENT) {
            // Drain to the end so trailing garbage or truncation is reported.
            while (readNode()) {
            }
            return false;
        }
    }
    return false;
}

xmlNodePtr XmlInput::expand() {
    xmlNodePtr n = xmlTextReaderExpand(impl_->reader);
    if (!n && status_.ok()) {
        const std::string msg = impl_->first_error.empty() ? "malformed XML" : impl_->first_error;
        fail(fatal::kXmlMalformed,
             impl_->first_error_line > 0 ? impl_->first_error_line : xmlTextReaderGetParserLineNumber(impl_->reader),
             msg);
    }
    return n;
}

std::string XmlInput::currentLocalName() const {
    const xmlChar* s = xmlTextReaderConstLocalName(impl_->reader);
    return s ? reinterpret_cast<const char*>(s) : "";
}

std::string XmlInput::currentNamespace() const {
    const xmlChar* s = xmlTextReaderConstNamespaceUri(impl_->reader);
    return s ? reinterpret_cast<const char*>(s) : "";
}

uint64_t XmlInput::bytesConsumed() const {
    const long n = impl_->reader ? xmlTextReaderByteConsumed(impl_->reader) : 0;
    return n > 0 ? static_cast<uint64_t>(n) : 0;
}

// --- DOM helpers -----------------------------------------------------------------

bool isNamed(xmlNodePtr n, const char* local_name) {
    return isElement(n) && std::strcmp(localName(n), local_name) == 0;
}

static bool nsStartsWith(xmlNsPtr ns, const char* prefix) {
    return ns && ns->href && std::strncmp(reinterpret_cast<const char*>(ns->href), prefix, std::strlen(prefix)) == 0;
}

std::string gmlId(xmlNodePtr n) { return std::string(gmlIdView(n)); }

std::string_view gmlIdView(xmlNodePtr n) {
    for (xmlAttrPtr a = n->properties; a; a = a->next)
        if (std::strcmp(reinterpret_cast<const char*>(a->name), "id") == 0 &&
            nsStartsWith(a->ns, "http://www.opengis.net/gml") && a->children && a->children->content)
            return reinterpret_cast<const char*>(a->children->content);
    return {};
}

std::string xlinkHref(xmlNodePtr n) {
    for (xmlAttrPtr a = n->properties; a; a = a->next)
        if (std::strcmp(reinterpret_cast<const char*>(a->name), "href") == 0 &&
            nsStartsWith(a->ns, "http://www.w3.org/1999/xlink") && a->children && a->children->content) {
            const char* s = reinterpret_cast<const char*>(a->children->content);
            return s[0] == '#' ? std::string(s + 1) : std::string(s);
        }
    return {};
}

std::string attribute(xmlNodePtr n, const char* local_name) {
    for (xmlAttrPtr a = n->properties; a; a = a->next)
        if (std::strcmp(reinterpret_cast<const char*>(a->name), local_name) == 0 && a->children &&
            a->children->content)
            return reinterpret_cast<const char*>(a->children->content);
    return {};
}

std::string text(xmlNodePtr n) {
    std::string out;
    for (xmlNodePtr c = n->children; c; c = c->next)
        if ((c->type == XML_TEXT_NODE || c->type == XML_CDATA_SECTION_NODE) && c->content)
            out += reinterpret_cast<const char*>(c->content);
    return out;
}

int64_t lineOf(xmlNodePtr n) { return xmlGetLineNo(n); }

xmlNodePtr firstChild(xmlNodePtr n) {
    for (xmlNodePtr c = n ? n->children : nullptr; c; c = c->next)
        if (isElement(c)) return c;
    return nullptr;
}

xmlNodePtr nextSibling(xmlNodePtr n) {
    for (xmlNodePtr c = n->next; c; c = c->next)
        if (isElement(c)) return c;
    return nullptr;
}

xmlNodePtr child(xmlNodePtr n, const char* local_name) {
    for (xmlNodePtr c = firstChild(n); c; c = nextSibling(c))
        if (isNamed(c, local_name)) return c;
    return nullptr;
}

}  // namespace cityatlas::citygml
