// SPDX-License-Identifier: MIT
/*
 * snapshot.c - see snapshot.h.
 *
 * The three buffers of a slot are always a permutation: one the writer
 * owns (back), one the reader owns (front), one in between (mid). The
 * exchanges hand buffers over with acquire/release ordering, so the bytes
 * written before a release are what the other side reads after its
 * acquire; no buffer is ever touched by both sides at once.
 */
#include "publish/snapshot.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

#define SNAP_NEW 4u /* mid holds a buffer the reader has not taken */

int snap_init(struct snap *s, int n)
{
	s->n = n;
	s->slot = calloc((size_t)n + 1, sizeof(*s->slot));
	if (!s->slot)
		return -ENOMEM;
	for (int i = 0; i < n; i++) {
		s->slot[i].back = 0;
		atomic_init(&s->slot[i].mid, 1);
		s->slot[i].front = 2;
	}
	return 0;
}

void snap_free(struct snap *s)
{
	free(s->slot);
	s->slot = NULL;
	s->n = 0;
}

static void describe(struct snap_slot *sl, const struct out_msg *m)
{
	memcpy(sl->name, m->describe->avatar_name, sizeof(sl->name));
	sl->site = m->describe->site;
}

void snap_put_batch(struct snap *s, const bool *wants, const struct out_msg *m, int n, uint64_t now_mono)
{
	for (int j = 0; j < n; j++) {
		struct snap_slot *sl;
		struct snap_entry *e;
		int a = m[j].avatar;

		if (a >= s->n || !wants[a])
			continue;
		sl = &s->slot[a];
		if (m[j].type == WIRE_DESCRIBE) {
			describe(sl, &m[j]);
			continue;
		}
		if (m[j].type != WIRE_FRAME)
			continue;
		e = &sl->buf[sl->back];
		e->f = *m[j].frame;
		memcpy(e->buttons, m[j].frame->in.buttons, sizeof(e->buttons));
		memcpy(e->analog, m[j].frame->in.analog, sizeof(e->analog));
		e->put_mono_ns = now_mono;
		memcpy(e->name, sl->name, sizeof(e->name));
		e->site = sl->site;
		sl->back = atomic_exchange_explicit(&sl->mid, sl->back | SNAP_NEW, memory_order_acq_rel) & 3u;
	}
}

const struct snap_entry *snap_take(struct snap *s, int i, bool *fresh)
{
	struct snap_slot *sl = &s->slot[i];

	*fresh = false;
	if (atomic_load_explicit(&sl->mid, memory_order_relaxed) & SNAP_NEW) {
		sl->front = atomic_exchange_explicit(&sl->mid, sl->front, memory_order_acq_rel) & 3u;
		sl->seen = true;
		*fresh = true;
	}
	return sl->seen ? &sl->buf[sl->front] : NULL;
}
