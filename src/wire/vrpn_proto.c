// SPDX-License-Identifier: MIT
/*
 * vrpn_proto.c - VRPN's message framing, cookies and descriptions, shared by
 * our VRPN server and our VRPN client (see vrpn_proto.h).
 */
#include "wire/vrpn_proto.h"

uint8_t *vrpn_msg_header(uint8_t *p, int32_t type, int32_t sender, uint64_t t_ns, size_t payload)
{
	vrpn_put32(p, (uint32_t)(VRPN_HEADER_LEN + payload));
	vrpn_put32(p + 4, (uint32_t)(t_ns / 1000000000ull));
	vrpn_put32(p + 8, (uint32_t)(t_ns % 1000000000ull / 1000u));
	vrpn_put32(p + 12, (uint32_t)sender);
	vrpn_put32(p + 16, (uint32_t)type);
	vrpn_put32(p + 20, 0); /* VRPN puts a sequence number for sniffers here; no peer reads it */
	memset(p + VRPN_HEADER_LEN, 0, VRPN_MSG_LEN(payload) - VRPN_HEADER_LEN);
	return p + VRPN_HEADER_LEN;
}

size_t vrpn_msg_description(uint8_t *p, int32_t kind, int32_t id, const char *name, uint64_t t_ns)
{
	size_t n = strlen(name) + 1;
	uint8_t *q = vrpn_msg_header(p, kind, id, t_ns, 4 + n);

	vrpn_put32(q, (uint32_t)n);
	memcpy(q + 4, name, n);
	return VRPN_MSG_LEN(4 + n);
}

void vrpn_cookie(uint8_t out[VRPN_COOKIE_LEN])
{
	memset(out, 0, VRPN_COOKIE_LEN);
	/* the magic, two spaces, the log mode we ask of the peer (none) */
	memcpy(out, VRPN_MAGIC "  0", VRPN_MAGIC_LEN + 3);
}

bool vrpn_cookie_ok(const uint8_t *ck)
{
	/* the major version must match; a different minor only makes VRPN warn */
	return !memcmp(ck, VRPN_MAGIC, VRPN_MAJOR_LEN) && ck[VRPN_MAGIC_LEN + 2] >= '0' &&
	       ck[VRPN_MAGIC_LEN + 2] <= '3';
}

enum vrpn_split_rc vrpn_split(const uint8_t *buf, size_t len, struct vrpn_header *h, size_t *total)
{
	if (len < VRPN_HEADER_LEN)
		return VRPN_SPLIT_MORE;
	h->len = vrpn_get32(buf);
	if (h->len < VRPN_HEADER_LEN || h->len > VRPN_LONGEST)
		return VRPN_SPLIT_BAD;
	h->sec = vrpn_get32(buf + 4);
	h->usec = vrpn_get32(buf + 8);
	h->sender = (int32_t)vrpn_get32(buf + 12);
	h->type = (int32_t)vrpn_get32(buf + 16);
	*total = VRPN_MSG_LEN(h->len - VRPN_HEADER_LEN);
	return len < *total ? VRPN_SPLIT_MORE : VRPN_SPLIT_OK;
}

bool vrpn_description_name(const uint8_t *pl, size_t plen, char name[VRPN_NAME_MAX])
{
	uint32_t n;

	if (plen < 4)
		return false;
	n = vrpn_get32(pl);
	if (n < 1 || n > VRPN_NAME_MAX || 4 + (size_t)n > plen)
		return false;
	memcpy(name, pl + 4, n);
	name[n - 1] = '\0';
	return true;
}
