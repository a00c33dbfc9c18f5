// SPDX-License-Identifier: MIT
// The block kernel for AVX-512 (VL, BW, DQ) with 8-lane vectors: the AVX2
// code, compiled so that the lane masks live in mask registers (masked adds,
// no and-then-add). Chosen at run time; bitwise the same results.
#define CED_KERNEL_NAME block_kernel_avx512
#define CED_KERNEL_NAME_COMPACT compact_avx512
#define CED_KERNEL_NAME_BALLS balls_avx512
#define CED_KERNEL_NAME_SPLIT split_avx512
#define CED_KERNEL_NAME_SELECT select_in_box_avx512
#define CED_KERNEL_NAME_ROWS rows_avx512
#define CED_KERNEL_NAME_CELL_KEYS cell_keys_avx512
#define CED_KERNEL_NAME_SELECT_IDS select_ids_in_box_avx512
#include "core/kernel/block_kernel.inc"
#include "core/kernel/grid_kernel.inc"
