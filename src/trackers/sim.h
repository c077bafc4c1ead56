/* SPDX-License-Identifier: MIT */
/*
 * sim.h - the options of sim.c's configuration sections (its keys' values).
 */
#ifndef AGW_SIM_H
#define AGW_SIM_H

#include "config/config.h"

struct sim_opts {
	int people;
	uint32_t seed;
	double sample_rate; /* Hz */
	double spacing;	    /* m between simulated people */
};

#endif /* AGW_SIM_H */
