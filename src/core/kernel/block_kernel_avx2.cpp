// SPDX-License-Identifier: MIT
// The block kernel for AVX2 (compiled with -mavx2, chosen at run time).
#define CED_KERNEL_NAME block_kernel_avx2
#define CED_KERNEL_NAME_COMPACT compact_avx2
#define CED_KERNEL_NAME_BALLS balls_avx2
#define CED_KERNEL_NAME_SPLIT split_avx2
#define CED_KERNEL_NAME_SELECT select_in_box_avx2
#define CED_KERNEL_NAME_ROWS rows_avx2
#define CED_KERNEL_NAME_CELL_KEYS cell_keys_avx2
#define CED_KERNEL_NAME_SELECT_IDS select_ids_in_box_avx2
#include "core/kernel/block_kernel.inc"
#include "core/kernel/grid_kernel.inc"
