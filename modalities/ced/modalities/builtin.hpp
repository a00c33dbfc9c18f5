// SPDX-License-Identifier: MIT
// The built-in modalities: the one list that ced/core.hpp, the registry of
// specs (src/core/registry.cpp), the installed headers (CMakeLists.txt reads
// the includes below) and the Python helpers (ced.<name>, made from the
// registry) follow. A new built-in is its header (spec_name, spec_help,
// from_spec), an include and an entry below, a test and a section in
// docs/MODALITIES.md.
#pragma once

#include "ced/modalities/bands.hpp"
#include "ced/modalities/corner.hpp"
#include "ced/modalities/intensity.hpp"
#include "ced/modalities/lab.hpp"
#include "ced/modalities/normals.hpp"
#include "ced/modalities/rgb.hpp"
#include "ced/modalities/sam.hpp"
#include "ced/modalities/xyz.hpp"

namespace ced {

/// A list of modality types.
template <class... M>
struct modality_types {
  /// Calls f(static_cast<M*>(nullptr)) for each type M, in order.
  template <class F>
  static void for_each(F&& f) {
    (f(static_cast<M*>(nullptr)), ...);
  }
};

using builtin_modalities = modality_types<xyz, rgb, lab, normals, intensity, bands, corner, sam>;

}  // namespace ced
