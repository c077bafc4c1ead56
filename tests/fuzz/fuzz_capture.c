// SPDX-License-Identifier: MIT
/*
 * fuzz_capture.c - the capture text format (src/trackers/capture.c): hex
 * reports, one per line, with optional timestamps, as the hardware drivers
 * play them (capture = FILE) and avatargw-decode reads them.
 *
 * Invariants: a parsed capture has reports back to back in its byte
 * buffer, each 1 to CAPTURE_MAX_REPORT bytes; timestamps are finite, start
 * at 0 and never go back, all present or all absent (timed); and every
 * report is the line's hex digits (each report's bytes are read here).
 */
#include "fuzz/fuzz.h"

#include "trackers/capture.h"

#include <string.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	char *text = malloc(size + 1), err[256];
	struct capture c;
	uint32_t next = 0;
	unsigned sum = 0;

	FUZZ_CHECK(text, "out of memory");
	memcpy(text, data, size);
	text[size] = '\0';
	if (capture_parse(&c, "fuzz", text, err, sizeof(err))) {
		free(text);
		return 0;
	}
	FUZZ_CHECK(c.n > 0, "a capture without reports");
	for (int i = 0; i < c.n; i++) {
		const struct capture_report *r = &c.rep[i];

		FUZZ_CHECK(r->off == next && r->len >= 1 && r->len <= CAPTURE_MAX_REPORT, "report %d: %u bytes at %u",
			   i, r->len, r->off);
		FUZZ_CHECK(c.timed ? isfinite(r->t) && r->t >= 0 && (i ? r->t >= c.rep[i - 1].t : r->t == 0) : r->t < 0,
			   "report %d at %g", i, r->t);
		for (unsigned k = 0; k < r->len; k++)
			sum += c.bytes[r->off + k];
		next = r->off + r->len;
	}
	(void)sum;
	capture_free(&c);
	free(text);
	return 0;
}
