// SPDX-License-Identifier: MIT
/*
 * site_none.c - the daemon built without Cyclone DDS (cyclonedds-dev was
 * missing): a [site] section is refused at start-up, nothing else changes.
 */
#include "sites/site.h"

#include <errno.h>

const bool site_built_in = false;

int site_open(struct site **out, const struct config *cfg, uint32_t source_id, char *err, size_t errlen)
{
	(void)cfg;
	(void)source_id;
	*out = NULL;
	snprintf(err, errlen,
		 "[site]: not built in (this avatargw was built without Cyclone DDS: install cyclonedds-dev, "
		 "cyclonedds-tools and rebuild)");
	return -ENOSYS;
}

void site_describe_local(struct site *s, int idx, const struct wire_describe *d)
{
	(void)s;
	(void)idx;
	(void)d;
}

int site_start(struct site *s, char *err, size_t errlen)
{
	(void)s;
	(void)err;
	(void)errlen;
	return -ENOSYS;
}

void site_close(struct site *s)
{
	(void)s;
}

int site_n_remote(const struct site *s)
{
	(void)s;
	return 0;
}

uint16_t site_remote_id(const struct site *s, int k)
{
	(void)s;
	return (uint16_t)k;
}

void site_put(struct site *s, int idx, const uint8_t *msg, size_t len)
{
	(void)s;
	(void)idx;
	(void)msg;
	(void)len;
}

void site_flush(struct site *s)
{
	(void)s;
}

bool site_remote(struct site *s, int k, uint64_t now_mono, struct wire_frame *wf, struct wire_describe *d,
		 bool *described, bool *fresh)
{
	(void)s;
	(void)k;
	(void)now_mono;
	(void)wf;
	(void)d;
	*described = *fresh = false;
	return false;
}

void site_report(struct site *s, FILE *out, bool json)
{
	(void)s;
	(void)out;
	(void)json;
}

bool site_remote_name(struct site *s, int k, char *buf, size_t len, bool *live)
{
	(void)s;
	(void)k;
	(void)buf;
	(void)len;
	*live = false;
	return false;
}

bool site_keeps(const struct site *s, const struct config *cfg)
{
	(void)s;
	(void)cfg;
	return false;
}

bool site_keeps_describe(const struct site *s, int idx, const struct wire_describe *d)
{
	(void)s;
	(void)idx;
	(void)d;
	return false;
}

void site_adopt(struct site *s, const struct config *cfg)
{
	(void)s;
	(void)cfg;
}

void site_remote_site(struct site *s, int k, struct wire_site *ws)
{
	(void)s;
	(void)k;
	(void)ws;
}
