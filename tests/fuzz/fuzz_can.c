// SPDX-License-Identifier: MIT
/*
 * fuzz_can.c - CAN frames and candump lines (src/wire/cancodec.c, as the
 * can source (src/trackers/can_in.c) and tools use it): a line parsed into a
 * frame, the frame decoded as a sensor's orientation or position of a
 * source's map, and as an avatar's frame of the can output's layout.
 *
 * Input: byte 0 picks the source's map (identifiers 11- or 29-bit, with
 * or without positions, sensors, scales and component order within what
 * the configuration allows); bit 7 set: the rest is raw frames (identifier
 * u32 LE, length u8, 8 data bytes); clear: candump -L lines.
 *
 * Invariants: a parsed frame formats back to a line that parses to the
 * same frame; a decoded orientation is a finite unit quaternion, a
 * position finite, for a sensor of the map; the decoders never read past
 * the frame's length.
 */
#include "fuzz/fuzz.h"

#include "wire/cancodec.h"

#include <errno.h>
#include <string.h>

static void decode(const struct cancodec_sensor_map *m, const struct can_frame *f, canid_t id0)
{
	struct cancodec_sensor_value v;
	struct cancodec_avatar a;
	int rc = cancodec_decode_sensor(m, f, &v);

	FUZZ_CHECK(rc == 0 || rc == -ENOENT || rc == -EBADMSG || rc == -EDOM, "decode_sensor returned %d", rc);
	if (rc == 0) {
		FUZZ_CHECK(v.sensor >= 0 && v.sensor < m->n, "sensor %d of %d", v.sensor, m->n);
		if (v.kind == CANCODEC_ORIENTATION)
			fuzz_unit_quat(v.v, "orientation");
		else
			fuzz_finite(v.v, 3, "position");
	}
	memset(&a, 0, sizeof(a));
	rc = cancodec_decode_avatar(f, id0, &a);
	FUZZ_CHECK(rc == -ENOENT || rc == -EBADMSG || (rc >= CANCODEC_STATUS && rc <= CANCODEC_LEFT_2),
		   "decode_avatar returned %d", rc);
	for (int j = 0; rc >= 0 && j < CANCODEC_JOINTS; j++) {
		double r = cancodec_rad(a.joint[j]);

		FUZZ_CHECK(a.joint[j] == CANCODEC_UNKNOWN ? isnan(r) : isfinite(r), "joint %d", j);
		FUZZ_CHECK(a.joint[j] == CANCODEC_UNKNOWN || cancodec_centideg(r) == a.joint[j], "joint %d round trip",
			   j);
	}
}

static void round_trip(const struct can_frame *f)
{
	char line[128], ifname[32];
	struct can_frame g;
	uint64_t t;

	FUZZ_CHECK(cancodec_format_line(f, 1700000000123456ull, "vcan0", line, sizeof(line)) > 0, "format");
	FUZZ_CHECK(cancodec_parse_line(line, &g, &t, ifname, sizeof(ifname)) == 0, "'%s' does not parse", line);
	FUZZ_CHECK(g.can_id == f->can_id && g.len == f->len && !memcmp(g.data, f->data, f->len) &&
			   t == 1700000000123456ull && !strcmp(ifname, "vcan0"),
		   "'%s' parses to another frame", line);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	static const double qs[4] = { 32768, 32767, 1, 1e9 }, ps[4] = { 0.001, 1e-9, 1e3, 0.01 };
	struct cancodec_sensor_map m;
	canid_t eff, id0;
	uint8_t v;

	if (size < 1)
		return 0;
	v = data[0];
	eff = v & 0x40 ? CAN_EFF_FLAG : 0;
	m = (struct cancodec_sensor_map){
		.ori_id = (v & 0x40 ? 0x1abcde00 : 0x200) | eff,
		.pos_id = v & 0x20 ? CANCODEC_NO_ID : (v & 0x40 ? 0x1abcdf00 : 0x280) | eff,
		.n = 1 + (v & 0x10 ? 15 : 3),
		.quat_scale = qs[v & 3],
		.xyzw = v & 4,
		.pos_scale = ps[(v >> 2) & 3],
	};
	id0 = v & 0x40 ? 0x1abcd000 | CAN_EFF_FLAG : 0x100;
	if (v & 0x80) {
		for (size_t at = 1; at + 13 <= size; at += 13) {
			struct can_frame f;

			memset(&f, 0, sizeof(f));
			f.can_id = (canid_t)data[at] | (canid_t)data[at + 1] << 8 | (canid_t)data[at + 2] << 16 |
				   (canid_t)data[at + 3] << 24;
			f.len = data[at + 4] % (CAN_MAX_DLEN + 1);
			memcpy(f.data, data + at + 5, 8);
			decode(&m, &f, id0);
		}
		return 0;
	}
	{
		char *text = malloc(size), *line, *next;

		FUZZ_CHECK(text, "out of memory");
		memcpy(text, data + 1, size - 1);
		text[size - 1] = '\0';
		for (line = text; line; line = next) {
			struct can_frame f;
			uint64_t t;
			char ifname[16];

			next = strchr(line, '\n');
			if (next)
				*next++ = '\0';
			if (cancodec_parse_line(line, &f, &t, ifname, sizeof(ifname)))
				continue;
			FUZZ_CHECK(f.len <= CAN_MAX_DLEN, "length %d", f.len);
			round_trip(&f);
			decode(&m, &f, id0);
		}
		free(text);
	}
	return 0;
}
