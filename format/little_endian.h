// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// Little-endian fields of the binary files we write (features/bounds,
/// blockmap): a plain copy, as the hosts we build for are little-endian.

#include <bit>
#include <cstdint>
#include <cstring>

namespace cityatlas::format {

static_assert(std::endian::native == std::endian::little, "the binary formats are little-endian, as this machine");

/// Writes v at `at` (sizeof(T) bytes there must be ours).
template <typename T>
void putLe(uint8_t* at, T v) {
    std::memcpy(at, &v, sizeof(T));
}
/// Reads a T at `at`.
template <typename T>
T getLe(const uint8_t* at) {
    T v;
    std::memcpy(&v, at, sizeof(T));
    return v;
}

}  // namespace cityatlas::format
