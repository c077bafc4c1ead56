// SPDX-License-Identifier: MIT
/*
 * fuzz_modbus_in.c - the modbus source's conversion of registers to poses
 * (modbus_in_decode_pose, src/trackers/modbus_in.c): every register format,
 * word order and orientation form, with scales at the ends of what the
 * configuration allows.
 *
 * Input: bytes 0-2 pick the [source] section (formats, orientation, word
 * order, scales); the rest are the registers, big-endian as on the wire
 * (two sensors 16 registers apart; missing ones read 0).
 *
 * Invariant: a pose the conversion accepts is a finite position and a
 * finite unit quaternion.
 */
#include "fuzz/fuzz.h"

#include "config/config.h"
#include "trackers/modbus_in.h"

#include <string.h>

#define REGS 32

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	static const char *const fmt[] = { "int16", "uint16", "int32", "uint32", "float32" };
	static const char *const ori[] = { "rotvec", "quat_wxyz", "quat_xyzw", "rpy", "none" };
	static const char *const word[] = { "abcd", "cdab", "badc", "dcba" };
	/* the ends of each scale's range in the configuration, and values of real devices */
	static const char *const pscale[] = { "0.001", "1e-9", "1000", "1", "0.0001", "1e-05", "0.1", "0.01" };
	static const char *const oscale[] = { "0.001", "1e-12", "1000", "1", "0.0001", "3.0517578125e-05",
					      "1e-06", "0.01" };
	static struct config cfg;
	uint16_t img[REGS] = { 0 };
	char text[512], err[256];
	int pf, of;

	if (size < 3)
		return 0;
	pf = data[0] % 5;
	of = data[1] % 5;
	/* position x y z from 0, the orientation right after it, the next sensor 16 registers on */
	snprintf(text, sizeof(text),
		 "[source m]\ntype = modbus\naddress = 127.0.0.1\nsensors = 2\nsensor_stride = 16\n"
		 "position_register = 0\nposition_format = %s\nposition_scale = %s\n"
		 "orientation_register = %d\norientation_format = %s\norientation_scale = %s\n"
		 "orientation = %s\nword_order = %s\n",
		 fmt[pf], pscale[data[2] & 7], pf >= 2 ? 6 : 3, fmt[of], oscale[(data[2] >> 3) & 7],
		 ori[(data[1] / 5) % 5], word[(data[0] / 5) % 4]);
	if (config_load_text(&cfg, "fuzz", text, err, sizeof(err))) {
		fprintf(stderr, "fuzz: %s\n%s", err, text);
		abort();
	}
	for (size_t i = 0; i < REGS && 3 + 2 * i + 1 < size; i++)
		img[i] = (uint16_t)(data[3 + 2 * i] << 8 | data[3 + 2 * i + 1]);
	for (int k = 0; k < 2; k++) {
		double q[4], p[3];

		if (!modbus_in_decode_pose(cfg.source[0].opt, img, 0, k, q, p))
			continue;
		fuzz_unit_quat(q, "orientation");
		fuzz_finite(p, 3, "position");
	}
	config_free(&cfg);
	return 0;
}
