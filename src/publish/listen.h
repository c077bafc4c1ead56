/* SPDX-License-Identifier: MIT */
/*
 * listen.h - the listening TCP socket of a server output (the stream
 * output, the Modbus server): non-blocking, close-on-exec, SO_REUSEADDR,
 * bound to the output's address (empty: every interface) and port.
 */
#ifndef AGW_LISTEN_H
#define AGW_LISTEN_H

#include "config/config.h"

#include <stdbool.h>
#include <stddef.h>

/*
 * reuseport: also SO_REUSEPORT, so that a reload can open the new server
 * before the old one closes. what: the server's name in the error ("listen",
 * "Modbus server"). Returns the descriptor, or a negative errno with err
 * saying which output, where and why.
 */
int out_listen_tcp(const struct cfg_output *cfg, const char *what, bool reuseport, char *err, size_t errlen);

#endif /* AGW_LISTEN_H */
