// SPDX-License-Identifier: MIT
/*
 * fuzz_ctl.c - the control socket's requests (ctl_answer,
 * src/daemon/ctl.c): a request line as a client sends it (the server takes
 * at most 127 bytes, up to the first CR or LF), answered by a gateway whose
 * loop runs: a stepped replay of the built-in clip and a simulated person,
 * an avatar on each.
 *
 * Invariants: every request gets an answer (one or more lines ending in a
 * newline); "reload" and nothing else asks for a reload; nothing reads
 * past the request.
 */
#include "fuzz/fuzz.h"

#include "daemon/ctl.h"

#include <string.h>
#include <time.h>

static struct gateway g;
static struct loop *loop;
static struct ctl_rates rates;
static struct ctl_info info;

static void setup(void)
{
	static const char text[] = "[daemon]\nlock_memory = no\ncontrol_socket =\nrate = 240\n"
				   "[source clip]\ntype = replay\nfile = builtin:cmu_141_16.csv\nstep = yes\n"
				   "[source sim]\ntype = sim\n"
				   "[avatar demo]\nid = 0\nperson = clip\n"
				   "[avatar p]\nid = 1\nperson = sim/p0\n";
	struct config cfg;
	char err[512];
	struct timespec ts;

	if (config_load_text(&cfg, "fuzz", text, err, sizeof(err)) || gw_open(&g, &cfg, NULL, 1, err, sizeof(err)) ||
	    loop_start(&loop, &g, err, sizeof(err))) {
		fprintf(stderr, "fuzz: %s\n", err);
		abort();
	}
	clock_gettime(CLOCK_MONOTONIC, &ts);
	ctl_rates_update(&rates, &g);
	info = (struct ctl_info){ &g, loop, &rates, (double)ts.tv_sec, "fuzz", 0, 0 };
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	char *line = malloc(size + 1), *text;
	char req[128];
	size_t len = 0;
	bool reload = false;

	if (!loop)
		setup();
	FUZZ_CHECK(line, "out of memory");
	memcpy(line, data, size);
	line[size] = '\0';
	/* the request as ctl_answer reads it, for the checks */
	snprintf(req, sizeof(req), "%s", line);
	req[strcspn(req, "\r\n")] = '\0';
	text = ctl_answer(line, &info, &reload, &len);
	FUZZ_CHECK(text, "no answer (memory)");
	FUZZ_CHECK(len > 0 && text[len - 1] == '\n', "request '%s': no answer, or one without a newline", req);
	FUZZ_CHECK(reload == !strcmp(req, "reload"), "request '%s': reload %d", req, reload);
	free(text);
	free(line);
	return 0;
}
