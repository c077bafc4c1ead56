/* SPDX-License-Identifier: MIT */
/*
 * ikt.h - the IK core's portable self-test (tests/embedded/ikt.c) and what
 * it needs from the platform it runs on: a Cortex-M under QEMU with
 * semihosting (ikt_mcu.c) or a Linux process (ikt_host.c). The test itself
 * uses no libc: freestanding targets link nothing but libgcc.
 */
#ifndef IKT_H
#define IKT_H

#include <stdint.h>

/* the platform: one string out; a cycle counter (0: none); stack probes (0: none) */
void ikt_puts(const char *s);
/* counts processor clock ticks (SysTick on Cortex-M); ikt_ticks_per_k() instructions per 1000 ticks */
uint32_t ikt_ticks(void);
uint32_t ikt_ticks_per_k(void);
/* paints the unused stack below the caller; ikt_stack_used() then says how deep anything called since went */
void ikt_stack_paint(void);
uint32_t ikt_stack_used(void);
/* the platform's name, printed with the results */
extern const char ikt_platform[];

/* the test: prints its findings, returns 0 if everything passed */
int ikt_run(void);

#endif /* IKT_H */
