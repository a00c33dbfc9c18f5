// SPDX-License-Identifier: MIT
// ced::core in one include: the cloud, parameters, the modality concept and
// the built-in modalities, runtime modalities and their registry, detect(),
// exact tiles.
#pragma once

#include "ced/centroid_distance.hpp"
#include "ced/channels.hpp"
#include "ced/cloud.hpp"
#include "ced/detect.hpp"
#include "ced/modalities/builtin.hpp"
#include "ced/modality.hpp"
#include "ced/neighborhood.hpp"
#include "ced/params.hpp"
#include "ced/preprocess.hpp"
#include "ced/scaled.hpp"
#include "ced/tile_geometry.hpp"
#include "ced/version.hpp"
