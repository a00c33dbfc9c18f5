// SPDX-License-Identifier: MIT
// Deprecated: this header was renamed ced/tile_geometry.hpp (the exact-tile
// geometry of an in-memory cloud; ced/tiled.hpp has the runs over files).
// Include ced/tile_geometry.hpp; this one forwards to it and will go away.
#pragma once

#include "ced/tile_geometry.hpp"
