// SPDX-License-Identifier: MIT
#pragma once

#define CED_VERSION_MAJOR 0
#define CED_VERSION_MINOR 1
#define CED_VERSION_PATCH 0
#define CED_VERSION_STRING "0.1.0"
