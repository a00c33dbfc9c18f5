// SPDX-License-Identifier: MIT
// The block kernel for the baseline instruction set (SSE2 on x86-64).
#define CED_KERNEL_NAME block_kernel_generic
#define CED_KERNEL_NAME_COMPACT compact_generic
#define CED_KERNEL_NAME_BALLS balls_generic
#define CED_KERNEL_NAME_SPLIT split_generic
#define CED_KERNEL_NAME_SELECT select_in_box_generic
#define CED_KERNEL_NAME_SELECT_IDS select_ids_in_box_generic
#include "core/kernel/block_kernel.inc"
#include "core/kernel/grid_kernel.inc"
