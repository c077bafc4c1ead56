/* SPDX-License-Identifier: MIT */
/*
 * capture.h - a capture of raw device reports, as text: what a hardware
 * driver reads instead of its device (capture = FILE), what
 * avatargw-decode decodes, what a bug report attaches.
 *
 * One report per line: its bytes in hex, two digits each, spaces between
 * bytes allowed ("01 00 34 00 ..." or "01003400..."). A line may start with
 * a timestamp, seconds with a decimal point ("12.004000 01 00 34 ..."),
 * the moment the report arrived; with timestamps a capture plays at the
 * pace it was recorded, without them at the device's nominal rate. Empty
 * lines and lines starting with '#' are ignored. For the Hydra a report is
 * one HID input report; for Polhemus it is one bulk IN transfer (records
 * may straddle two of them, as on the wire).
 */
#ifndef AGW_CAPTURE_H
#define AGW_CAPTURE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define CAPTURE_MAX_REPORT 4096 /* bytes of one report at most */

struct capture_report {
	double t;     /* s since the capture's first report; < 0: no timestamp */
	uint32_t off; /* into capture.bytes */
	uint16_t len;
	uint32_t line; /* in the file, for messages */
};

struct capture {
	uint8_t *bytes;
	struct capture_report *rep;
	int n;
	bool timed; /* every report has a timestamp */
};

/*
 * Reads a whole capture file. Returns 0, or -1 with err naming the file
 * and line of the first line that is not a report (a capture with an
 * unreadable line is refused whole: it was written by a tool or by hand,
 * and silently playing part of it would hide the mistake).
 */
int capture_load(struct capture *c, const char *path, char *err, size_t errlen);
/* the same from text in memory (name is what errors call it) */
int capture_parse(struct capture *c, const char *name, const char *text, char *err, size_t errlen);
void capture_free(struct capture *c);

#endif /* AGW_CAPTURE_H */
