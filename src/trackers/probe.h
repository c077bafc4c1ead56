/* SPDX-License-Identifier: MIT */
/*
 * probe.h - avatargw --probe: a network tracker looked at for a moment
 * (vrpn://NAME@host[:port], dtrack://[address]:port), what it sends
 * listed, and the configuration lines that read it.
 */
#ifndef AGW_PROBE_H
#define AGW_PROBE_H

#include <stdio.h>

/* runs the source for secs seconds; 0 when samples came, 1 when none did, 64 for a URL it does not take */
int tracker_probe(const char *url, double secs, FILE *out, FILE *err);

#endif /* AGW_PROBE_H */
