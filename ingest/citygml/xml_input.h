// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// A streaming XML input for CityGML on libxml2's xmlTextReader, hardened for
// files downloaded from anywhere: no network, no DTD loading, no entity
// substitution, and any DOCTYPE is refused (CityGML never needs one; it is how
// external-entity and entity-expansion attacks arrive). Parse errors become
// one line naming the file and line.
//
// Usage: open(), then rootElement(), then nextChild() over the root's
// children; expand() gives the DOM subtree of the current child, valid until
// the next nextChild() call (memory stays at one city object).

#include <libxml/parser.h>
#include <libxml/tree.h>

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

#include "core/status.h"

namespace cityatlas::citygml {

/// libxml2 options for every CityGML parse: no NOENT (no entity
/// substitution), no DTDLOAD/DTDATTR, NONET; BIG_LINES keeps line numbers
/// right past 65535; HUGE is NOT set, so libxml2's own limits on text nodes
/// and entity amplification stay on.
inline constexpr int kXmlParseOptions = XML_PARSE_NONET | XML_PARSE_BIG_LINES | XML_PARSE_NOCDATA | XML_PARSE_COMPACT;

inline constexpr const char* kDoctypeRefused =
    "DOCTYPE declarations are refused (CityGML needs none; they carry external-entity and entity-expansion attacks)";

/// Once per process: libxml2 initialised and every external entity refused.
void installXmlGuards();

/// The checks before any parse: the file opens; it is not empty, whitespace
/// only, binary or plain text ("io_error: ...", "empty_file: ...",
/// "not_xml: ..."). Gives the file's size.
Status sniffXmlFile(const std::filesystem::path& file, uint64_t* file_size);

class XmlInput {
public:
    XmlInput();
    ~XmlInput();
    XmlInput(const XmlInput&) = delete;
    XmlInput& operator=(const XmlInput&) = delete;

    /// Opens the file; fails with code-prefixed messages: "io_error: ...",
    /// "empty_file: ...", "not_xml: ...".
    Status open(const std::filesystem::path& file);
    /// Moves to the root element. Fails on malformed XML or a DOCTYPE.
    Status rootElement(std::string* local_name, std::string* namespace_uri);
    /// Moves to the next element child of the root; false at the end (check
    /// status() then: a parse error ends the walk too).
    bool nextChild();
    /// DOM subtree of the current root child (owned by the reader).
    xmlNodePtr expand();
    std::string currentLocalName() const;
    std::string currentNamespace() const;
    /// Bytes consumed so far (for progress).
    uint64_t bytesConsumed() const;
    uint64_t fileSize() const { return file_size_; }
    /// The first error met, as "code: file:line: message"; ok when none.
    const Status& status() const { return status_; }

    struct Impl;  // libxml2 state (public for the C error callback)

private:
    bool readNode();  // one xmlTextReaderRead with error handling
    void fail(const char* code, int64_t line, const std::string& message);
    Impl* impl_;
    std::filesystem::path file_;
    uint64_t file_size_ = 0;
    Status status_;
    bool at_child_ = false;
};

// --- DOM helpers over expanded subtrees -------------------------------------

/// Local name of an element ("Polygon" for gml:Polygon).
inline const char* localName(xmlNodePtr n) { return reinterpret_cast<const char*>(n->name); }
inline bool isElement(xmlNodePtr n) { return n && n->type == XML_ELEMENT_NODE; }
bool isNamed(xmlNodePtr n, const char* local_name);
/// gml:id (GML 3.1.1 or 3.2), or empty.
std::string gmlId(xmlNodePtr n);
/// gmlId() without a copy: valid while the node lives.
std::string_view gmlIdView(xmlNodePtr n);
/// xlink:href without a leading '#', or empty.
std::string xlinkHref(xmlNodePtr n);
/// An attribute by local name (any namespace), or empty.
std::string attribute(xmlNodePtr n, const char* local_name);
/// Concatenated text content of the element's direct text children.
std::string text(xmlNodePtr n);
int64_t lineOf(xmlNodePtr n);
/// First element child with this local name, or null.
xmlNodePtr child(xmlNodePtr n, const char* local_name);
/// Iteration over element children: for (xmlNodePtr c = firstChild(n); c; c = nextSibling(c))
xmlNodePtr firstChild(xmlNodePtr n);
xmlNodePtr nextSibling(xmlNodePtr n);

}  // namespace cityatlas::citygml
