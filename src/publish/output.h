/* SPDX-License-Identifier: MIT */
/*
 * output.h - where messages go: one const struct of operations per
 * transport (udp.c: unicast and multicast; stream.c: TCP and Unix; vrpn.c;
 * osc.c: VMC and VRChat; websocket.c: JSON and the viewer), listed in
 * outputs.c's table by config type.
 *
 * The loop hands every output the same batch of encoded messages once per
 * cycle. send() never blocks: what the kernel or a subscriber cannot take
 * now is dropped and counted. service() accepts and retires subscribers.
 */
#ifndef AGW_OUTPUT_H
#define AGW_OUTPUT_H

#include "base/counter.h"
#include "config/config.h"
#include "avatargw/wire.h"
#include "frames/frame.h"

#include <stdatomic.h>
#include <stdint.h>
#include <stdio.h>

struct out_msg {
	const uint8_t *data; /* the message as the wire carries it (UDP, streams and recordings send it as is) */
	uint16_t len;
	uint8_t type;	 /* WIRE_FRAME or WIRE_DESCRIBE */
	uint16_t avatar; /* index into the gateway's avatars */
	/*
	 * What data encodes, as the cycle made it: an output that needs the
	 * values reads them here and never parses the bytes. FRAME: frame
	 * (its input block in frame->in, zero when the sensors have none);
	 * DESCRIBE: describe. Valid during send() only.
	 */
	const struct wire_frame *frame;
	const struct wire_describe *describe;
};

/* a message from its values: encodes them into buf (WIRE_MAX_MSG bytes) and points at both */
static inline struct out_msg out_msg_frame(const struct wire_frame *f, uint8_t *buf, uint16_t avatar)
{
	return (struct out_msg){ buf, (uint16_t)wire_encode_frame(f, buf), WIRE_FRAME, avatar, f, NULL };
}

static inline struct out_msg out_msg_describe(const struct wire_describe *d, uint8_t *buf, uint16_t avatar)
{
	return (struct out_msg){ buf, (uint16_t)wire_encode_describe(d, buf), WIRE_DESCRIBE, avatar, NULL, d };
}

struct output_stats {
	_Atomic uint64_t sent;	    /* messages handed to the kernel */
	_Atomic uint64_t dropped;   /* messages a full socket or subscriber could not take */
	_Atomic uint64_t errors;    /* other send errors */
	_Atomic uint64_t clients;   /* stream subscribers now */
	_Atomic uint64_t accepted;  /* stream subscribers ever */
	_Atomic uint64_t refused;   /* over max_clients */
	_Atomic uint64_t closed;    /* subscribers that went away or were too slow for too long */
	_Atomic uint64_t gso_off;   /* UDP segmentation offload refused by the kernel: now off */
	_Atomic uint64_t malformed; /* clients dropped for breaking their protocol (vrpn) */
	_Atomic int32_t last_errno;
};

struct output;

struct output_ops {
	/* its name, keys, options and checks, as the configuration sees them */
	struct cfg_type type;
	/* a new client asks for no burst of DESCRIBEs (Modbus: an HMI may connect for every poll) */
	bool quiet_accept;
	int (*open)(struct output *o, char *err, size_t errlen);
	void (*close)(struct output *o);
	void (*send)(struct output *o, const struct out_msg *m, int n);
	void (*service)(struct output *o);
	/* moves what subscribers hold from old to o (a reload keeps them); may be NULL */
	bool (*adopt)(struct output *o, struct output *old);
	/*
	 * The transport's own counters for avatargw-ctl status (control
	 * thread): JSON members after a comma (",\"x\":1"), or one line of
	 * text. May be NULL.
	 */
	void (*report)(struct output *o, FILE *out, bool json);
};

struct output {
	const struct output_ops *ops;
	const struct cfg_output *cfg;
	char name[CFG_NAME_MAX];
	bool *wants;   /* per avatar index */
	uint16_t *ids; /* per avatar index: its id (vrpn device names) */
	int n_avatars;
	uint32_t cycle; /* for decimation */
	bool adopted;	/* priv was taken over from the previous configuration */
	/* during open() only: the same-named output of the configuration a reload replaces, or NULL */
	struct output *prev;
	struct output_stats st;
	void *priv;
};

/* the table: index = cfg_output.type (outputs.c) */
extern const struct output_ops *const outputs_table[];
extern const int outputs_count;

/* start-up: opens the transport; wants[] from the config's avatar list (ids by index) */
/* old: an output of the configuration being replaced, whose subscribers this one may take over */
int output_open(struct output *o, const struct cfg_output *cfg, const uint16_t *avatar_ids, int n_avatars,
		struct output *old, char *err, size_t errlen);
/* gives adopted subscribers back (a reload that failed) */
void output_unadopt(struct output *o, struct output *old);
void output_close(struct output *o);

#endif /* AGW_OUTPUT_H */
