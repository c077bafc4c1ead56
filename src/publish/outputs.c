// SPDX-License-Identifier: MIT
/*
 * outputs.c - the transports by config type, and what every output shares.
 */
#include "publish/output.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const struct output_ops *const outputs_table[] = {
	[CFG_OUT_UDP] = &udp_output_ops,       [CFG_OUT_MULTICAST] = &udp_output_ops,
	[CFG_OUT_TCP] = &stream_output_ops,    [CFG_OUT_UNIX] = &stream_output_ops,
	[CFG_OUT_MODBUS] = &modbus_output_ops, [CFG_OUT_CAN] = &can_output_ops,
	[CFG_OUT_VRPN] = &vrpn_output_ops,     [CFG_OUT_VMC] = &vmc_output_ops,
	[CFG_OUT_VRCHAT] = &vrchat_output_ops, [CFG_OUT_WEBSOCKET] = &websocket_output_ops,
};

int output_open(struct output *o, const struct cfg_output *cfg, const uint16_t *avatar_ids, int n_avatars,
		struct output *old, char *err, size_t errlen)
{
	int rc;

	memset(o, 0, sizeof(*o));
	if (cfg->type < 0 || (size_t)cfg->type >= sizeof(outputs_table) / sizeof(outputs_table[0]) ||
	    !outputs_table[cfg->type]) {
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
	rc = o->ops->open(o, err, errlen);
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
