// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// Outcome of an operation that can fail for reasons outside the program
/// (bad input, full disk, unknown CRS): carried up to cli/, which prints the
/// one-line message and picks the exit code. Programmer errors are asserts.

#include <string>
#include <utility>

namespace cityatlas {

struct Status {
    std::string error;  ///< one line naming the file and place; empty when ok
    bool ok() const { return error.empty(); }
    static Status Ok() { return {}; }
    static Status Fail(std::string message) { return Status{std::move(message)}; }
};

}  // namespace cityatlas
