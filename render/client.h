// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// The render stage (not implemented yet; see issue "The streaming client"):
/// a GL-free selection / memory-budget core and a thin OpenGL backend that
/// stream a tile folder.

#include "tiles/tileset.h"
