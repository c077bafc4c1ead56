/* SPDX-License-Identifier: MIT */
/*
 * regcodec.h - 32-bit values in two 16-bit Modbus registers, in any of the
 * four word orders devices use.
 *
 * Name the bytes of the value's big-endian form A B C D (A the most
 * significant). A register travels high byte first, so each order says
 * which bytes the first and the second register carry:
 *
 *   ABCD  r[0] = A B, r[1] = C D   (big endian, Modbus's own byte order)
 *   CDAB  r[0] = C D, r[1] = A B   (word swap: Kinova, mbpoll's default)
 *   BADC  r[0] = B A, r[1] = D C   (byte swap)
 *   DCBA  r[0] = D C, r[1] = B A   (little endian)
 *
 * Registers are host integers (uint16_t) as libmodbus hands them over.
 * Floats are IEEE 754 binary32, copied bit for bit (a NaN stays a NaN).
 * Debian 12's libmodbus 3.1.6 float setters put the bytes in the wrong
 * places (docs/MODBUS.md), hence this file. Pure functions, no state.
 */
#ifndef AGW_REGCODEC_H
#define AGW_REGCODEC_H

#include <stdint.h>

/* the same values as enum cfg_word_order: bit 0 swaps the words, bit 1 the bytes in each */
enum regcodec_order { REGCODEC_ABCD = 0, REGCODEC_CDAB = 1, REGCODEC_BADC = 2, REGCODEC_DCBA = 3 };

void regcodec_put_u32(uint16_t r[2], uint32_t v, int order);
uint32_t regcodec_get_u32(const uint16_t r[2], int order);
void regcodec_put_f32(uint16_t r[2], float v, int order);
float regcodec_get_f32(const uint16_t r[2], int order);
/* "ABCD", ... */
const char *regcodec_order_name(int order);

#endif /* AGW_REGCODEC_H */
