// SPDX-License-Identifier: GPL-3.0-or-later
// (in progress)
#include <gtest/gtest.h>
