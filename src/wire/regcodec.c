// SPDX-License-Identifier: MIT
/*
 * regcodec.c - see regcodec.h.
 */
#include "wire/regcodec.h"

#include <string.h>

static uint16_t swap16(uint16_t x)
{
	return (uint16_t)(x << 8 | x >> 8);
}

void regcodec_put_u32(uint16_t r[2], uint32_t v, int order)
{
	uint16_t hi = (uint16_t)(v >> 16), lo = (uint16_t)v;

	if (order & 2) {
		hi = swap16(hi);
		lo = swap16(lo);
	}
	r[0] = order & 1 ? lo : hi;
	r[1] = order & 1 ? hi : lo;
}

uint32_t regcodec_get_u32(const uint16_t r[2], int order)
{
	uint16_t hi = order & 1 ? r[1] : r[0], lo = order & 1 ? r[0] : r[1];

	if (order & 2) {
		hi = swap16(hi);
		lo = swap16(lo);
	}
	return (uint32_t)hi << 16 | lo;
}

void regcodec_put_f32(uint16_t r[2], float v, int order)
{
	uint32_t u;

	memcpy(&u, &v, sizeof(u));
	regcodec_put_u32(r, u, order);
}

float regcodec_get_f32(const uint16_t r[2], int order)
{
	uint32_t u = regcodec_get_u32(r, order);
	float v;

	memcpy(&v, &u, sizeof(v));
	return v;
}

const char *regcodec_order_name(int order)
{
	static const char *const names[] = { "ABCD", "CDAB", "BADC", "DCBA" };

	return names[order & 3];
}
