/* SPDX-License-Identifier: MIT */
/*
 * ctl.h - the control socket (avatargw-ctl): a Unix stream socket served by
 * the control thread. A client sends one line ("status", "status json",
 * "reload", "step [N] [SOURCE]") and reads the answer until EOF.
 */
#ifndef AGW_CTL_H
#define AGW_CTL_H

#include "daemon/gateway.h"
#include "daemon/loop.h"

#include <stdio.h>

/* "auto": $RUNTIME_DIRECTORY/control, else $XDG_RUNTIME_DIR/avatargw.control, else /tmp/avatargw-UID.control */
void ctl_resolve_path(const char *configured, char *out, size_t len);

struct ctl_rates {
	double t; /* CLOCK_MONOTONIC seconds of the last sample */
	int n_trackers, n_avatars;
	uint64_t *trk_samples;
	uint64_t *av_frames;
	double *trk_rate;
	double *av_rate;
};

struct ctl_info {
	struct gateway *g;
	struct loop *l;
	struct ctl_rates *rates;
	double started; /* CLOCK_MONOTONIC seconds */
	const char *config_name;
	uint64_t reloads, reload_failures;
};

int ctl_listen(const char *path);
void ctl_close(int fd, const char *path);
/* serves one client if one is waiting; want_reload set when it asked for one */
void ctl_serve(int lfd, const struct ctl_info *info, bool *want_reload);
/* renders the status (human or JSON) */
void ctl_status(FILE *out, const struct ctl_info *info, bool json);
/* updates the per-second rates (control thread, once a second) */
int ctl_rates_update(struct ctl_rates *r, struct gateway *g);
void ctl_rates_free(struct ctl_rates *r);

#endif /* AGW_CTL_H */
