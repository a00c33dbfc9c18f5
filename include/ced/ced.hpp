// SPDX-License-Identifier: MIT
// Umbrella header (ced::ced): the detector and the built-in modalities
// (ced/core.hpp), and reading and writing every supported file format
// (ced::io::read_cloud, ced::io::write_cloud). Evaluation (ced/eval.hpp),
// rendering (ced/render.hpp) and plugins (ced/plugin.hpp) have their own.
#pragma once

#include "ced/core.hpp"
#include "ced/io/io.hpp"
