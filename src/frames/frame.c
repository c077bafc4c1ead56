// SPDX-License-Identifier: MIT
/*
 * frame.c - the latest samples of an avatar's three sensors, with states.
 */
#include "frames/frame.h"

#include <string.h>

#include "avatargw/wire.h"

void frame_gather(struct frame_source *src, uint64_t now_mono, uint64_t stale_ns, struct pose_frame *out)
{
	out->t_ns = 0;
	out->arrival_ns = 0;
	out->new_sample = false;
	out->inputs = 0;
	for (int i = 0; i < FRAME_SENSORS; i++) {
		const struct tracker *t = src->trk[i];
		const struct sensor_slot *s = &t->slot[src->sensor[i]];
		uint32_t tstate = atomic_load_explicit(&((struct tracker *)t)->st.state, memory_order_relaxed);

		if (!s->seen || tstate == TRACKER_FAULTY) {
			out->state[i] = WIRE_SENSOR_MISSING;
			out->buttons[i] = 0;
			for (int k = 0; k < SENSOR_ANALOG_MAX; k++)
				out->analog[i][k] = 0;
			out->age_ns[i] = s->seen && now_mono > s->arrival_ns ? now_mono - s->arrival_ns : 0;
			continue;
		}
		out->sensor[i] = s->pose;
		if (s->inputs)
			out->inputs |= (uint8_t)(1u << i);
		out->buttons[i] = s->buttons;
		for (int k = 0; k < SENSOR_ANALOG_MAX; k++)
			out->analog[i][k] = s->analog[k];
		out->age_ns[i] = now_mono > s->arrival_ns ? now_mono - s->arrival_ns : 0;
		out->state[i] = out->age_ns[i] > stale_ns ? WIRE_SENSOR_STALE : WIRE_SENSOR_OK;
		if (s->count != src->last_count[i]) {
			src->last_count[i] = s->count;
			out->new_sample = true;
			if (s->arrival_ns > out->arrival_ns)
				out->arrival_ns = s->arrival_ns;
		}
		if (s->t_ns > out->t_ns)
			out->t_ns = s->t_ns;
	}
}

void frame_inputs(const struct pose_frame *pf, struct wire_frame *wf)
{
	_Static_assert(WIRE_ANALOG == SENSOR_ANALOG_MAX, "the input block carries every analog value of a slot");
	if (!pf->inputs) {
		/* none: what the outputs read is zero (cleared once when the inputs went away) */
		if (wf->in.present)
			memset(&wf->in, 0, sizeof(wf->in));
		return;
	}
	wf->h.flags |= WIRE_F_INPUTS;
	wf->in.present = pf->inputs;
	for (int i = 0; i < FRAME_SENSORS; i++) {
		wf->in.buttons[i] = pf->buttons[i];
		for (int k = 0; k < WIRE_ANALOG; k++)
			wf->in.analog[i][k] = pf->analog[i][k];
	}
}
