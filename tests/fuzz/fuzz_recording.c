// SPDX-License-Identifier: MIT
/*
 * fuzz_recording.c - recording files (src/record/recfile.c, recload.c):
 * the header, the record framing with its resynchronisation after damage,
 * every record's decoder, and the index the replay source and avatargw-rec
 * build from a whole file.
 *
 * Input: byte 0 bit 0 clear: the rest is a file as it is. Set: the rest
 * is a recording's records without their framing (type u8, length u16 LE,
 * payload), framed and sealed here behind a good header, so that mutations
 * reach the decoders behind the CRCs; a length past the end takes what is
 * left.
 *
 * Invariants: recfile_next returns records and damage inside the buffer,
 * in order, covering each byte at most once; the index's events name
 * sensors it has, its damage lies inside the file; the decoders never read
 * past a record's payload.
 */
#include "fuzz/fuzz.h"

#include "fuzz/recframe.h"
#include "record/recload.h"

#include <string.h>

static void walk(const uint8_t *buf, size_t len)
{
	size_t off = RECFILE_HEADER_LEN, last = RECFILE_HEADER_LEN;
	struct recfile_record rec;
	struct recfile_damage dmg;

	if (len < RECFILE_HEADER_LEN)
		off = last = len;
	for (;;) {
		int got = recfile_next(buf, len, &off, &rec, &dmg);

		if (dmg.len) {
			FUZZ_CHECK(dmg.off >= last && dmg.off + dmg.len <= len, "damage %zu+%zu after %zu of %zu",
				   dmg.off, dmg.len, last, len);
			last = dmg.off + dmg.len;
		}
		if (!got)
			break;
		FUZZ_CHECK(rec.off >= last && rec.size == RECFILE_REC_OVERHEAD + (size_t)rec.len &&
				   rec.off + rec.size <= len && rec.payload == buf + rec.off + RECFILE_REC_HEAD &&
				   off == rec.off + rec.size,
			   "record at %zu, %zu bytes, after %zu of %zu", rec.off, rec.size, last, len);
		last = off;
		{
			/* the payload alone in a buffer of its size: a decoder reading past it is ASan's */
			uint8_t *pl = malloc(rec.len ? rec.len : 1);

			FUZZ_CHECK(pl, "out of memory");
			memcpy(pl, rec.payload, rec.len);
			switch (rec.type) {
			case RECFILE_SESSION: {
				struct recfile_session s;

				if (!recfile_session_parse(pl, rec.len, &s)) {
					for (int i = 0; i < s.n_sources; i++)
						for (uint32_t k = 0; k < s.sources[i].n_sensors; k++)
							FUZZ_CHECK(s.sources[i].sensor[k], "source %d sensor %u", i, k);
					recfile_session_free(&s);
				}
				break;
			}
			case RECFILE_SAMPLE: {
				struct recfile_sample s;

				(void)recfile_sample_decode(pl, rec.len, &s);
				break;
			}
			case RECFILE_GAP: {
				struct recfile_gap g;

				(void)recfile_gap_decode(pl, rec.len, &g);
				break;
			}
			case RECFILE_END: {
				struct recfile_end e;

				(void)recfile_end_decode(pl, rec.len, &e);
				break;
			}
			default:
				break;
			}
			(void)recfile_type_name(rec.type);
			free(pl);
		}
	}
}

static void index_file(const uint8_t *buf, size_t len)
{
	struct rec_index ix;
	char err[256], label[128];
	int sensor[3];

	if (rec_index_parse(buf, len, &ix, err, sizeof(err)))
		return;
	for (size_t i = 0; i < ix.n_events; i++)
		FUZZ_CHECK(ix.events[i].sensor < ix.n_sensors, "event %zu of sensor %u (%u sensors)", i,
			   ix.events[i].sensor, ix.n_sensors);
	for (uint32_t i = 0; i < ix.n_sensors; i++)
		FUZZ_CHECK(ix.names[i] && rec_index_sensor(&ix, ix.names[i]) >= 0, "sensor %u's name", i);
	for (size_t i = 0; i < ix.n_damage; i++)
		FUZZ_CHECK(ix.damage[i].off + ix.damage[i].len <= len, "damage %zu beyond the file", i);
	(void)rec_index_person(&ix, NULL, sensor, label, sizeof(label), err, sizeof(err));
	for (int i = 0; i < ix.session.n_sources; i++)
		(void)rec_index_person(&ix, ix.session.sources[i].name, sensor, label, sizeof(label), err, sizeof(err));
	rec_index_free(&ix);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	uint8_t *buf;
	size_t len;

	if (size < 1)
		return 0;
	if (data[0] & 1) {
		buf = fuzz_frame_records(data + 1, size - 1, data[0] & 2 ? RECFILE_F_MESSAGES : 0, &len);
	} else {
		len = size - 1;
		buf = malloc(len ? len : 1);
		FUZZ_CHECK(buf, "out of memory");
		memcpy(buf, data + 1, len);
	}
	{
		struct recfile_header h;

		(void)recfile_is_recording(buf, len);
		(void)recfile_header_decode(buf, len, &h);
	}
	walk(buf, len);
	index_file(buf, len);
	free(buf);
	return 0;
}
