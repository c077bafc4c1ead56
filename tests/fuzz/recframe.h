/* SPDX-License-Identifier: MIT */
/*
 * recframe.h - recordings made from fuzz input (fuzz_recording.c,
 * fuzz_replay.c): records given without their framing, framed and sealed
 * behind a good header, so that mutations reach what lies behind the CRCs.
 */
#ifndef AGW_FUZZ_RECFRAME_H
#define AGW_FUZZ_RECFRAME_H

#include "fuzz/fuzz.h"

#include "record/recfile.h"

#include <string.h>

/* the records of in (type, u16 length, payload) framed and sealed behind a good header */
static inline uint8_t *fuzz_frame_records(const uint8_t *in, size_t n, uint32_t flags, size_t *out_len)
{
	struct recfile_header h = { RECFILE_VERSION, 0, 1700000000000000000ull, 0 };
	size_t cap = RECFILE_HEADER_LEN + n / 3 * RECFILE_REC_OVERHEAD + n + RECFILE_REC_OVERHEAD, len;
	uint8_t *buf = malloc(cap);
	size_t at = 0;

	FUZZ_CHECK(buf, "out of memory");
	h.flags = flags;
	recfile_header_encode(&h, buf);
	len = RECFILE_HEADER_LEN;
	while (at + 3 <= n) {
		uint8_t type = in[at];
		size_t pl = (size_t)in[at + 1] | (size_t)in[at + 2] << 8;

		at += 3;
		if (pl > n - at)
			pl = n - at;
		FUZZ_CHECK(len + RECFILE_REC_OVERHEAD + pl <= cap, "framing buffer");
		recfile_frame(buf + len, type, (uint32_t)pl);
		memcpy(buf + len + RECFILE_REC_HEAD, in + at, pl);
		recfile_seal(buf + len);
		len += RECFILE_REC_OVERHEAD + pl;
		at += pl;
	}
	*out_len = len;
	return buf;
}

#endif /* AGW_FUZZ_RECFRAME_H */
