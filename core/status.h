// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// Outcome of an operation that can fail for reasons outside the program
/// (bad input, full disk, unknown CRS): a code that says what kind of failure
/// it is, for callers to branch on, and one line for people, naming the file
/// and the place. cli/ prints the line and picks the exit code from the code.
/// Programmer errors are asserts.

#include <cstdint>
#include <string>
#include <utility>

namespace cityatlas {

enum class StatusCode : uint8_t {
    kOk,
    kUsage,         ///< the command line or an option's value is wrong (exit 2)
    kIo,            ///< a file or connection cannot be opened, read or written
    kInvalidInput,  ///< the bytes are there but wrong: malformed, out of range, inconsistent
    kUnsupported,   ///< valid, but beyond what cityatlas does (a version, a feature, a GPU)
    kInternal,      ///< a check of our own output failed: a bug to report
};

/// "usage", "io", "invalid_input", "unsupported", "internal" ("ok").
const char* statusCodeName(StatusCode code);

struct Status {
    StatusCode code = StatusCode::kOk;
    std::string error;  ///< one line naming the file and place; empty when ok

    bool ok() const { return code == StatusCode::kOk; }
    static Status Ok() { return {}; }
    static Status Fail(StatusCode code, std::string message) { return Status{code, std::move(message)}; }
    static Status Usage(std::string message) { return Fail(StatusCode::kUsage, std::move(message)); }
    static Status Io(std::string message) { return Fail(StatusCode::kIo, std::move(message)); }
    static Status Invalid(std::string message) { return Fail(StatusCode::kInvalidInput, std::move(message)); }
    static Status Unsupported(std::string message) { return Fail(StatusCode::kUnsupported, std::move(message)); }
    static Status Internal(std::string message) { return Fail(StatusCode::kInternal, std::move(message)); }
    /// The same failure with `prefix` before its message ("node 12 (opaque): ...").
    Status within(const std::string& prefix) const { return ok() ? *this : Fail(code, prefix + error); }
};

inline const char* statusCodeName(StatusCode code) {
    switch (code) {
        case StatusCode::kOk: return "ok";
        case StatusCode::kUsage: return "usage";
        case StatusCode::kIo: return "io";
        case StatusCode::kInvalidInput: return "invalid_input";
        case StatusCode::kUnsupported: return "unsupported";
        case StatusCode::kInternal: return "internal";
    }
    return "internal";
}

}  // namespace cityatlas
