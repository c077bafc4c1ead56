// SPDX-License-Identifier: MIT
/*
 * ikt_host.c - the self-test's platform as a Linux process (x86-64 natively,
 * aarch64 under qemu-user): stdout, no cycle counter, no stack probe.
 */
#include <stdio.h>

#include "ikt.h"

#ifndef IKT_PLATFORM
#define IKT_PLATFORM "linux"
#endif

const char ikt_platform[] = IKT_PLATFORM;

void ikt_puts(const char *s)
{
	puts(s);
}

uint32_t ikt_ticks(void)
{
	return 0;
}

uint32_t ikt_ticks_per_k(void)
{
	return 0;
}

void ikt_stack_paint(void)
{
}

uint32_t ikt_stack_used(void)
{
	return 0;
}

int main(void)
{
	return ikt_run();
}
