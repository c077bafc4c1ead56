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

#include <poll.h>
#include <stdio.h>

/*
 * "auto": $RUNTIME_DIRECTORY/control, else $XDG_RUNTIME_DIR/avatargw.control,
 * else $TMPDIR/avatargw-UID/control (TMPDIR: /tmp when unset), a directory
 * ctl_open() makes with mode 0700
 */
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

/*
 * The control socket and its clients, served by the control thread without
 * ever waiting on one: a client has CTL_DEADLINE_S from its connection to
 * send its request line, and as long again to take the answer; then it is
 * closed. At most CTL_CLIENTS at once; more are told "error: busy".
 */
#define CTL_CLIENTS 8
#define CTL_DEADLINE_S 1.0

struct ctl_server;

/*
 * Listens at path (mode 0600), in a directory made (mode 0700) if missing;
 * refuses a directory every user may write to or that another user owns,
 * and a socket something already listens on. 0, or a negative errno with
 * err saying why.
 */
int ctl_open(struct ctl_server **out, const char *path, char *err, size_t errlen);
/* closes the clients and the socket, and removes the socket file if it is still ours */
void ctl_close(struct ctl_server *s);
/*
 * The descriptors to poll (pf[0]: the listening socket, then the clients);
 * lowers *wait_s to the next client's deadline. Returns how many.
 */
int ctl_pollfds(struct ctl_server *s, struct pollfd *pf, int max, double *wait_s);
/*
 * The answer to one request line (up to its first CR or LF, at most 127
 * bytes): malloc'd text of *len bytes, or NULL without memory; want_reload
 * set when it asks for one.
 */
char *ctl_answer(const char *line, const struct ctl_info *info, bool *want_reload, size_t *len);
/* after poll(): accepts, reads, answers, closes what is late; want_reload set when a client asked */
void ctl_serve(struct ctl_server *s, const struct pollfd *pf, int n, const struct ctl_info *info, bool *want_reload);
/* renders the status (human or JSON) */
void ctl_status(FILE *out, const struct ctl_info *info, bool json);
/* updates the per-second rates (control thread, once a second) */
int ctl_rates_update(struct ctl_rates *r, struct gateway *g);
void ctl_rates_free(struct ctl_rates *r);

#endif /* AGW_CTL_H */
