/* SPDX-License-Identifier: MIT */
/*
 * notify.h - a small sd_notify(3) client: one datagram to $NOTIFY_SOCKET
 * (a path, or an abstract name after '@'). Does nothing outside systemd.
 */
#ifndef AGW_NOTIFY_H
#define AGW_NOTIFY_H

#include <stdbool.h>
#include <stdint.h>

/* 0 if sent or not under systemd; a negative errno if sending failed */
int notify_send(const char *state);
int notify_sendf(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
/* the watchdog period systemd asks for (WATCHDOG_USEC for this pid), 0 = none */
uint64_t notify_watchdog_usec(void);

#endif /* AGW_NOTIFY_H */
