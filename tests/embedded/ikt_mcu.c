// SPDX-License-Identifier: MIT
/*
 * ikt_mcu.c - the self-test's platform on a bare Cortex-M under QEMU: the
 * vector table and reset handler, semihosting output and exit, SysTick as
 * the instruction counter, stack painting, and the memcpy/memset GCC emits
 * even in freestanding code. No libc.
 *
 * Semihosting: "bkpt 0xab" with the operation in r0 and its argument in r1.
 * SYS_EXIT with ADP_Stopped_ApplicationExit ends QEMU with status 0, any
 * other reason with status 1, so a script sees the verdict in $?.
 *
 * Instructions: under "qemu-system-arm -icount shift=0" every instruction
 * takes 1 ns of virtual time and SysTick counts the board's processor clock
 * in that time, so ticks are instructions times a constant. The constant is
 * measured at start-up with a loop of known length (two instructions per
 * turn). Without -icount the counts follow the host's clock and mean nothing.
 */
#include <stddef.h>
#include <stdint.h>

#include "ikt.h"

#ifndef IKT_PLATFORM
#define IKT_PLATFORM "cortex-m"
#endif

const char ikt_platform[] = IKT_PLATFORM;

#define SYS_WRITE0 0x04
#define SYS_EXIT 0x18
#define ADP_STOPPED_APPLICATION_EXIT 0x20026
#define ADP_STOPPED_RUN_TIME_ERROR 0x20023

#define SYST_CSR (*(volatile uint32_t *)0xe000e010)
#define SYST_RVR (*(volatile uint32_t *)0xe000e014)
#define SYST_CVR (*(volatile uint32_t *)0xe000e018)
#define CPACR (*(volatile uint32_t *)0xe000ed88)

#define PAINT 0x5a5aa5a5u

/* from the linker script */
extern uint32_t __data_load[], __data_start[], __data_end[], __bss_start[], __bss_end[];
extern uint32_t __stack_limit[], __stack_top[];

int main(void);
void ikt_reset(void);

static int semihost(int op, const void *arg)
{
	register int r0 __asm__("r0") = op;
	register const void *r1 __asm__("r1") = arg;

	__asm__ volatile("bkpt 0xab" : "+r"(r0) : "r"(r1) : "memory");
	return r0;
}

static void __attribute__((noreturn)) ikt_exit(int status)
{
	semihost(SYS_EXIT,
		 (const void *)(uintptr_t)(status ? ADP_STOPPED_RUN_TIME_ERROR : ADP_STOPPED_APPLICATION_EXIT));
	for (;;) {
	}
}

void ikt_puts(const char *s)
{
	semihost(SYS_WRITE0, s);
	semihost(SYS_WRITE0, "\n");
}

static void fault(void)
{
	ikt_puts("ikt: FAILED: fault exception");
	ikt_exit(1);
}

/* the Cortex-M vector table: every exception but reset is a failure of the test */
__attribute__((section(".vectors"), used)) static const uintptr_t vectors[16] = {
	(uintptr_t)__stack_top, /* initial stack pointer */
	(uintptr_t)ikt_reset,	/* reset */
	(uintptr_t)fault,	/* NMI */
	(uintptr_t)fault,	/* HardFault */
	(uintptr_t)fault,	/* MemManage (v7-M) */
	(uintptr_t)fault,	/* BusFault (v7-M) */
	(uintptr_t)fault,	/* UsageFault (v7-M) */
	0,			/* reserved */
	0,			/* reserved */
	0,			/* reserved */
	0,			/* reserved */
	(uintptr_t)fault,	/* SVCall */
	(uintptr_t)fault,	/* DebugMonitor (v7-M) */
	0,			/* reserved */
	(uintptr_t)fault,	/* PendSV */
	(uintptr_t)fault,	/* SysTick (counting only, its interrupt is off) */
};

static inline uintptr_t sp_now(void)
{
	uintptr_t sp;

	__asm__ volatile("mov %0, sp" : "=r"(sp));
	return sp;
}

/* paints from the stack's limit up to a little below the caller's frame */
static void paint_below(uintptr_t top)
{
	volatile uint32_t *p = __stack_limit;

	while ((uintptr_t)p < top)
		*p++ = PAINT;
}

/* the lowest address written since the paint, as a depth below top */
static uint32_t depth_below(uintptr_t top)
{
	const volatile uint32_t *p = __stack_limit;

	while ((uintptr_t)p < top && *p == PAINT)
		p++;
	return (uint32_t)(top - (uintptr_t)p);
}

static uintptr_t probe_top;

void ikt_stack_paint(void)
{
	/* the caller's frame ends near here; what lies below is the callee's */
	probe_top = sp_now() - 64;
	paint_below(probe_top);
}

uint32_t ikt_stack_used(void)
{
	return depth_below(probe_top) + 64;
}

uint32_t ikt_ticks(void)
{
	return 0xffffffu - SYST_CVR;
}

static uint32_t per_k;

uint32_t ikt_ticks_per_k(void)
{
	return per_k;
}

static void calibrate(void)
{
	uint32_t n = 200000, t0, ticks;

	t0 = ikt_ticks();
	__asm__ volatile(".syntax unified\n1:\tsubs %0, %0, #1\n\tbne 1b" : "+l"(n) : : "cc");
	ticks = (ikt_ticks() - t0) & 0xffffffu;
	/* 400 000 instructions (and a handful around them) */
	per_k = ticks ? (uint32_t)(400000000ull / ticks) : 0;
}

void ikt_reset(void)
{
	uint32_t *src = __data_load, *dst = __data_start;

#if defined(__ARM_FP)
	/* full access to CP10 and CP11 before any floating-point instruction */
	CPACR |= 0xfu << 20;
	__asm__ volatile("dsb\n\tisb" ::: "memory");
#endif
	while (dst < __data_end)
		*dst++ = *src++;
	for (dst = __bss_start; dst < __bss_end; dst++)
		*dst = 0;
	paint_below(sp_now() - 32);
	SYST_RVR = 0xffffff;
	SYST_CVR = 0;
	SYST_CSR = 5; /* enabled, processor clock, no interrupt */
	calibrate();
	{
		int rc = main();
		uint32_t total = depth_below((uintptr_t)__stack_top);
		char num[12];
		int n = (int)sizeof(num) - 1;

		num[n] = 0;
		do {
			num[--n] = (char)('0' + total % 10);
			total /= 10;
		} while (total && n > 0);
		semihost(SYS_WRITE0, "ikt: stack high-water mark of the whole program: ");
		semihost(SYS_WRITE0, num + n);
		ikt_puts(" bytes");
		ikt_exit(rc);
	}
}

/* GCC emits calls to these for structure copies even in freestanding code (used: kept through -flto) */
__attribute__((used)) void *memcpy(void *d, const void *s, size_t n)
{
	unsigned char *dp = d;
	const unsigned char *sp = s;

	while (n--)
		*dp++ = *sp++;
	return d;
}

__attribute__((used)) void *memset(void *d, int c, size_t n)
{
	unsigned char *dp = d;

	while (n--)
		*dp++ = (unsigned char)c;
	return d;
}

int main(void)
{
	return ikt_run();
}
