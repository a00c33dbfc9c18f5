// SPDX-License-Identifier: MIT
// Umbrella header: the detector, the built-in modalities and PLY I/O.
#pragma once

#include "ced/cloud.hpp"
#include "ced/detect.hpp"
#include "ced/io/ply.hpp"
#include "ced/modalities/bands.hpp"
#include "ced/modalities/intensity.hpp"
#include "ced/modalities/lab.hpp"
#include "ced/modalities/rgb.hpp"
#include "ced/modalities/xyz.hpp"
#include "ced/modality.hpp"
#include "ced/params.hpp"
#include "ced/version.hpp"
