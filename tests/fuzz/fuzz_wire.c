// SPDX-License-Identifier: MIT
/*
 * fuzz_wire.c - the protocol decoder (src/wire/wire.c): wire_peek, the FRAME
 * and DESCRIBE decoders, and the stream length prefix, on any bytes.
 *
 * Invariants: a decoded message encodes back to bytes that decode to the
 * very same struct (what a decoder accepts, the encoder can say); names
 * are NUL-terminated within their arrays; the decoders never read past len.
 */
#include "fuzz/fuzz.h"

#include "avatargw/wire.h"

#include <string.h>

static void check_names(const struct wire_describe *d)
{
	FUZZ_CHECK(memchr(d->avatar_name, 0, sizeof(d->avatar_name)), "avatar name not terminated");
	FUZZ_CHECK(memchr(d->conventions, 0, sizeof(d->conventions)), "conventions not terminated");
	for (int i = 0; i < WIRE_JOINTS; i++)
		FUZZ_CHECK(memchr(d->joint[i].name, 0, sizeof(d->joint[i].name)), "joint %d name", i);
	for (int i = 0; i < WIRE_SEGMENTS; i++)
		FUZZ_CHECK(memchr(d->segment[i].name, 0, sizeof(d->segment[i].name)), "segment %d name", i);
	for (int i = 0; i < WIRE_SENSORS; i++)
		FUZZ_CHECK(memchr(d->sensor[i], 0, sizeof(d->sensor[i])), "sensor %d name", i);
	FUZZ_CHECK(memchr(d->site.name, 0, sizeof(d->site.name)), "site name not terminated");
}

/* a name is a C string: what follows its first NUL is not part of it (nor encoded again) */
static void clean(char *s, size_t n)
{
	char *z = memchr(s, 0, n);

	if (z)
		memset(z, 0, n - (size_t)(z - s));
}

static void clean_names(struct wire_describe *d)
{
	clean(d->avatar_name, sizeof(d->avatar_name));
	clean(d->conventions, sizeof(d->conventions));
	for (int i = 0; i < WIRE_JOINTS; i++)
		clean(d->joint[i].name, sizeof(d->joint[i].name));
	for (int i = 0; i < WIRE_SEGMENTS; i++)
		clean(d->segment[i].name, sizeof(d->segment[i].name));
	for (int i = 0; i < WIRE_SENSORS; i++)
		clean(d->sensor[i], sizeof(d->sensor[i]));
	clean(d->site.name, sizeof(d->site.name));
}

/* what the encoder writes of its own (version, lengths, counts) may differ from a later version's */
static void same_header(const struct wire_header *a, const struct wire_header *b, const char *what)
{
	FUZZ_CHECK(a->type == b->type && a->flags == b->flags && a->source_id == b->source_id && a->seq == b->seq &&
			   a->describe_rev == b->describe_rev && a->sample_time_ns == b->sample_time_ns &&
			   a->avatar_id == b->avatar_id,
		   "%s header changed through encode and decode", what);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	static uint8_t buf[WIRE_MAX_MSG];
	struct wire_header h;
	int type = wire_peek(data, size, &h);

	if (size >= 4)
		(void)wire_get_len(data);
	if (type < 0)
		return 0;
	{
		static struct wire_frame f, f2;
		int rc;

		memset(&f, 0, sizeof(f));
		rc = wire_decode_frame(data, size, &f);
		if (rc == 0) {
			size_t n = wire_encode_frame(&f, buf);

			FUZZ_CHECK(n <= WIRE_MAX_MSG, "FRAME encoded to %zu bytes", n);
			memset(&f2, 0, sizeof(f2));
			FUZZ_CHECK(wire_decode_frame(buf, n, &f2) == 0, "re-encoded FRAME does not decode");
			same_header(&f.h, &f2.h, "FRAME");
			f2.h = f.h;
			FUZZ_CHECK(!memcmp(&f, &f2, sizeof(f)), "FRAME changed through encode and decode");
		}
	}
	{
		static struct wire_describe d, d2;
		int rc;

		memset(&d, 0, sizeof(d));
		rc = wire_decode_describe(data, size, &d);
		if (rc == 0) {
			size_t n;

			check_names(&d);
			clean_names(&d);
			n = wire_encode_describe(&d, buf);
			FUZZ_CHECK(n <= WIRE_MAX_MSG, "DESCRIBE encoded to %zu bytes", n);
			memset(&d2, 0, sizeof(d2));
			FUZZ_CHECK(wire_decode_describe(buf, n, &d2) == 0, "re-encoded DESCRIBE does not decode");
			same_header(&d.h, &d2.h, "DESCRIBE");
			d2.h = d.h;
			FUZZ_CHECK(!memcmp(&d, &d2, sizeof(d)), "DESCRIBE changed through encode and decode");
		}
	}
	return 0;
}
