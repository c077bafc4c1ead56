/* SPDX-License-Identifier: MIT */
/*
 * listen.h - what the server outputs (stream, Modbus, VRPN) share: the
 * listening TCP socket (non-blocking, close-on-exec, SO_REUSEADDR, bound
 * to the output's address, empty: every interface, and port), and the
 * non-blocking send of a client's pending bytes.
 */
#ifndef AGW_LISTEN_H
#define AGW_LISTEN_H

#include "config/config.h"

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

/*
 * reuseport: also SO_REUSEPORT, so that a reload can open the new server
 * before the old one closes. what: the server's name in the error ("listen",
 * "Modbus server"). Returns the descriptor, or a negative errno with err
 * saying which output, where and why.
 */
int out_listen_tcp(const char *name, const char *address, int port_no, const char *what, bool reuseport, char *err,
		   size_t errlen);

/*
 * Sends what the socket takes now of the len bytes at buf + *off, without
 * waiting; advances *off and *len (both 0 once all went). 0, or a negative
 * errno when the connection is broken (the caller drops the client).
 */
int out_send_pending(int fd, const uint8_t *buf, size_t *off, size_t *len);

#endif /* AGW_LISTEN_H */
