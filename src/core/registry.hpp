// SPDX-License-Identifier: MIT
// Private: what plugin loading needs of the modality registry.
#pragma once

#include <string>
#include <vector>

namespace ced::detail {

/// Starts recording the names that register_modality() registers, and keeps
/// the registry as it is now.
void begin_registration_log();
/// Stops recording and returns the names registered since (sorted, unique);
/// with `roll_back`, first restores the registry kept by the begin call.
std::vector<std::string> end_registration_log(bool roll_back);

}  // namespace ced::detail
