// SPDX-License-Identifier: MIT
/*
 * outputs.c - the transports by config type, and what every output shares.
 */
#include "publish/output.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/*
 * Every output type, one row each. Those whose library pkg-config did not
 * find at build time (the Makefile's HAVE_*) are left out, and the
 * configuration says so for their type.
 */
#ifndef HAVE_LIBMODBUS
#define HAVE_LIBMODBUS 1
#endif
#ifndef HAVE_LIBLO
#define HAVE_LIBLO 1
#endif
#ifndef HAVE_LIBWEBSOCKETS
#define HAVE_LIBWEBSOCKETS 1
#endif

extern const struct output_ops udp_output_ops, multicast_output_ops, tcp_output_ops, unix_output_ops, modbus_output_ops,
	can_output_ops, vrpn_output_ops, vmc_output_ops, vrchat_output_ops, websocket_output_ops;

const struct output_ops *const outputs_table[] = {
	&udp_output_ops,       &multicast_output_ops, &tcp_output_ops, &unix_output_ops,
#if HAVE_LIBMODBUS
	&modbus_output_ops,
#endif
	&can_output_ops,       &vrpn_output_ops,
#if HAVE_LIBLO
	&vmc_output_ops,       &vrchat_output_ops,
#endif
#if HAVE_LIBWEBSOCKETS
	&websocket_output_ops,
#endif
};

const int outputs_count = (int)(sizeof(outputs_table) / sizeof(outputs_table[0]));

/* types this build left out: known, so that the configuration can say why (doc: the missing library) */
static const struct cfg_type not_built[] = {
#if !HAVE_LIBMODBUS
	{ .name = "modbus", .doc = "libmodbus" },
#endif
#if !HAVE_LIBLO
	{ .name = "vmc", .doc = "liblo" },
	{ .name = "vrchat", .doc = "liblo" },
#endif
#if !HAVE_LIBWEBSOCKETS
	{ .name = "websocket", .doc = "libwebsockets" },
#endif
	{ .name = NULL },
};

const struct cfg_type *cfg_output_type(int i)
{
	if (i < 0)
		return NULL;
	if (i < outputs_count)
		return &outputs_table[i]->type;
	i -= outputs_count;
	return i < (int)(sizeof(not_built) / sizeof(not_built[0])) - 1 ? &not_built[i] : NULL;
}

int output_open(struct output *o, const struct cfg_output *cfg, const uint16_t *avatar_ids, int n_avatars,
		struct output *old, char *err, size_t errlen)
{
	int rc;

	memset(o, 0, sizeof(*o));
	if (cfg->type < 0 || cfg->type >= outputs_count) {
		snprintf(err, errlen, "[output %s] type: not built into this daemon", cfg->name);
		return -ENOSYS;
	}
	o->ops = outputs_table[cfg->type];
	o->cfg = cfg;
	o->n_avatars = n_avatars;
	snprintf(o->name, sizeof(o->name), "%s", cfg->name);
	o->wants = calloc((size_t)n_avatars + 1, sizeof(bool));
	o->ids = calloc((size_t)n_avatars + 1, sizeof(uint16_t));
	if (!o->wants || !o->ids) {
		free(o->wants);
		free(o->ids);
		o->wants = NULL;
		o->ids = NULL;
		snprintf(err, errlen, "[output %s]: out of memory", cfg->name);
		return -ENOMEM;
	}
	for (int i = 0; i < n_avatars; i++) {
		bool w = cfg->n_avatars == 0;

		o->ids[i] = avatar_ids[i];

		for (int j = 0; j < cfg->n_avatars; j++)
			w |= cfg->avatar_ids[j] == avatar_ids[i];
		o->wants[i] = w;
	}
	if (old && old->ops == o->ops && o->ops->adopt && o->ops->adopt(o, old)) {
		o->adopted = true;
		return 0;
	}
	o->prev = old && old->ops == o->ops ? old : NULL;
	rc = o->ops->open(o, err, errlen);
	o->prev = NULL;
	if (rc) {
		free(o->wants);
		free(o->ids);
		o->wants = NULL;
		o->ids = NULL;
	}
	return rc;
}

void output_close(struct output *o)
{
	if (o->ops && o->wants)
		o->ops->close(o);
	free(o->wants);
	free(o->ids);
	o->wants = NULL;
	o->ids = NULL;
	o->ops = NULL;
}

void output_unadopt(struct output *o, struct output *old)
{
	if (!o->adopted)
		return;
	old->priv = o->priv;
	o->priv = NULL;
	o->adopted = false;
}
