/* SPDX-License-Identifier: MIT */
/*
 * gwtest.h - a real gateway (daemon/gateway.h) driven by a test: the test
 * thread plays the loop (gw_cycle), decodes every FRAME the cycle
 * published and checks that nothing wrong went out.
 */
#ifndef AGW_TEST_GWTEST_H
#define AGW_TEST_GWTEST_H

#include "avatargw/wire.h"
#include "daemon/gateway.h"

#include <stdbool.h>
#include <stdint.h>

struct gwt {
	struct gateway g;
	struct wire_frame f; /* the last FRAME published */
	uint64_t frames;
	char notes[8192]; /* what the drivers left for the log, one per line */
	bool open;
};

/* opens a gateway on config text; fails the test on an error */
void gwt_open(struct gwt *t, const char *conf);
void gwt_close(struct gwt *t);
/* a cmocka teardown: closes the gateway a failed test left open (its device threads would go on) */
int gwt_teardown(void **state);
/* one cycle now; decodes its FRAME into t->f and checks it (fails the test on anything wrong) */
void gwt_cycle(struct gwt *t);
/* cycles every 2 ms until pred holds or ms pass; returns the ms it took, or -1 */
int gwt_until(struct gwt *t, bool (*pred)(struct gwt *t, void *arg), void *arg, int ms);
/* cycles for ms */
void gwt_run(struct gwt *t, int ms);
/* the tracker named name */
struct tracker *gwt_tracker(struct gwt *t, const char *name);
uint32_t gwt_state(struct gwt *t, const char *name);
/* takes the drivers' notes into t->notes */
void gwt_take_notes(struct gwt *t);
uint64_t gwt_ms(void);
void gwt_sleep_ms(int ms);

/* predicates */
bool gwt_tracker_ok(struct gwt *t, void *name); /* the tracker is OK and its last frame's sensors too */
bool gwt_tracker_faulty(struct gwt *t, void *name);
bool gwt_tracker_stale(struct gwt *t, void *name);
bool gwt_tracker_ended(struct gwt *t, void *name); /* a capture played to its end */

#endif /* AGW_TEST_GWTEST_H */
