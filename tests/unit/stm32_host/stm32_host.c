/* SPDX-License-Identifier: MIT */
/* The register blocks of the STM32 drivers on the host, and the core
 * (stm32_host.h says how a model sees the driver's accesses). The core's
 * System Control Space (0xE000E000, one page: SCB, SysTick, NVIC) is a model
 * here; the peripherals' are in their own files. */
#define _GNU_SOURCE
#include "stm32_host.h"

#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <ucontext.h>
#include <unistd.h>

#if !defined(__x86_64__) || !defined(__linux__)
#error "stm32_host single-steps the driver's register accesses: x86-64 Linux only"
#endif

#define PAGE                 4096u
#define MAX_BLOCKS           16u
#define MAX_IRQS             96
#define TRAP_FLAG            0x100   /* EFLAGS.TF */
#define PF_WRITE             0x2     /* page-fault error code: a write */
#define HANDLER_MAX_ACCESSES 100000u /* one handler's accesses before it counts as hung */

static stm32_host_periph_t *blocks[MAX_BLOCKS];
static unsigned n_blocks;

/* The access the trap flag is single-stepping, between its two signals. */
static struct {
    stm32_host_periph_t *p;
    uint32_t off;
    bool write;
} open;

static uint64_t cycles;
static uint32_t clock_hz = 168000000u;
static bool primask;
static bool reset_requested;
static void (*vectors[MAX_IRQS + 1])(void); /* [0] SysTick, [1 + n] IRQ n */
static bool pending[MAX_IRQS + 1];
static unsigned taken[MAX_IRQS + 1];
static struct {
    void (*tick)(void *ctx, uint64_t cycles);
    void *ctx;
} tickers[8];
static unsigned n_tickers;
static bool in_handler;
static unsigned handler_accesses; /* register accesses of the running handler */
static int active = -2;           /* the interrupt whose handler runs */
static struct {
    void (*level)(void *ctx);
    void *ctx;
} levels[8];
static unsigned n_levels;

static unsigned slot(int irqn) { return (unsigned)(irqn + 1); }

/* ------------------------------------------------------------ the traps */

/* The block an address falls in: its registers, not merely its page. */
static stm32_host_periph_t *find(const volatile void *addr)
{
    const uintptr_t a = (uintptr_t)addr;
    for (unsigned i = 0; i < n_blocks; i++) {
        if (a >= blocks[i]->base && a < (uintptr_t)blocks[i]->base + blocks[i]->size) {
            return blocks[i];
        }
    }
    return NULL;
}

static void *page_of(const stm32_host_periph_t *p)
{
    return (void *)(uintptr_t)(p->base & ~(PAGE - 1u));
}

static void protect(stm32_host_periph_t *p, int prot)
{
    if (mprotect(page_of(p), PAGE, prot) != 0) {
        abort();
    }
}

static uint32_t *word(stm32_host_periph_t *p, uint32_t off)
{
    return (uint32_t *)(uintptr_t)(p->mem + off);
}

static void on_segv(int sig, siginfo_t *info, void *ctx)
{
    stm32_host_periph_t *p = find(info->si_addr);
    if (p == NULL) {
        /* A real fault: die of it. */
        signal(sig, SIG_DFL);
        return;
    }
    ucontext_t *uc = ctx;
    const uint32_t off = (uint32_t)((uintptr_t)info->si_addr - p->base) & ~3u;
    /* The instructions up to this access take their time first. */
    stm32_host_spend(STM32_HOST_ACCESS_CYCLES);
    protect(p, PROT_READ | PROT_WRITE);
    /* Every access reads first: a write of a byte or a read-modify-write
     * keeps the register's other bits as they are. */
    *word(p, off) = p->read != NULL ? p->read(p, off) : p->reg[off / 4u];
    open.p = p;
    open.off = off;
    open.write = (uc->uc_mcontext.gregs[REG_ERR] & PF_WRITE) != 0;
    p->accesses++;
    if (in_handler && ++handler_accesses > HANDLER_MAX_ACCESSES) {
        /* A handler looping on a register that never changes: on a core, a
         * hang until the watchdog; here a failure that says so. */
        static const char msg[] = "stm32_host: a handler made 100000 register accesses: a hang\n";
        (void)write(2, msg, sizeof msg - 1u);
        abort();
    }
    uc->uc_mcontext.gregs[REG_EFL] |= TRAP_FLAG;
}

static void on_trap(int sig, siginfo_t *info, void *ctx)
{
    (void)sig;
    (void)info;
    ucontext_t *uc = ctx;
    uc->uc_mcontext.gregs[REG_EFL] &= ~(greg_t)TRAP_FLAG;
    stm32_host_periph_t *p = open.p;
    if (p == NULL) {
        return;
    }
    if (open.write) {
        const uint32_t v = *word(p, open.off);
        if (p->write != NULL) {
            p->write(p, open.off, v);
        } else {
            p->reg[open.off / 4u] = v;
        }
    }
    protect(p, PROT_NONE);
    open.p = NULL;
    /* Between two instructions: where the core takes an interrupt that is
     * pending and not masked, as it would in the middle of a driver's
     * polling loop. A handler's own accesses trap in turn (SA_NODEFER);
     * it is not interrupted itself (one level). */
    stm32_host_take_interrupts();
}

void stm32_host_map(stm32_host_periph_t *p)
{
    if (n_blocks == MAX_BLOCKS || (p->base & (PAGE - 1u)) + p->size > PAGE) {
        abort();
    }
    /* At the block's own address: the driver's constant instance pointers
     * (stm32_regs.h) and the core's (cortex_m.h) reach it as on the MCU. A
     * page other blocks share is mapped once. */
    bool mapped = false;
    for (unsigned i = 0; i < n_blocks; i++) {
        mapped = mapped || page_of(blocks[i]) == page_of(p);
    }
    if (!mapped) {
        void *m = mmap(page_of(p), PAGE, PROT_NONE,
                       MAP_PRIVATE | MAP_ANONYMOUS | MAP_FIXED_NOREPLACE, -1, 0);
        if (m != page_of(p)) {
            fprintf(stderr, "stm32_host: cannot map %s's registers at 0x%08x\n", p->name, p->base);
            abort();
        }
    }
    p->mem = (volatile uint8_t *)(uintptr_t)p->base;
    p->accesses = 0u;
    blocks[n_blocks++] = p;
}

/* ------------------------------------------------------------ time */

uint64_t stm32_host_cycles(void) { return cycles; }

void stm32_host_spend(uint64_t n)
{
    cycles += n;
    for (unsigned i = 0; i < n_tickers; i++) {
        tickers[i].tick(tickers[i].ctx, cycles);
    }
}

void stm32_host_set_clock(uint32_t hz) { clock_hz = hz; }
uint32_t stm32_host_clock(void) { return clock_hz; }

void stm32_host_on_time(void (*tick)(void *ctx, uint64_t), void *ctx)
{
    if (n_tickers == sizeof tickers / sizeof tickers[0]) {
        abort();
    }
    tickers[n_tickers].tick = tick;
    tickers[n_tickers].ctx = ctx;
    n_tickers++;
}

void stm32_host_run_us(uint64_t us)
{
    /* In steps of a microsecond, so that interrupts are taken near when
     * they fall due. */
    const uint64_t per_us = clock_hz / 1000000u;
    for (uint64_t i = 0; i < us; i++) {
        stm32_host_spend(per_us);
        stm32_host_take_interrupts();
    }
}

/* ------------------------------------------------------- the interrupts */

void stm32_host_vector(int irqn, void (*handler)(void)) { vectors[slot(irqn)] = handler; }

void stm32_host_pend(int irqn)
{
    if (irqn != active) {
        pending[slot(irqn)] = true;
    }
}

void stm32_host_on_level(void (*level)(void *ctx), void *ctx)
{
    if (n_levels == sizeof levels / sizeof levels[0]) {
        abort();
    }
    levels[n_levels].level = level;
    levels[n_levels].ctx = ctx;
    n_levels++;
}

unsigned stm32_host_taken(int irqn) { return taken[slot(irqn)]; }

bool stm32_host_masked(void) { return primask; }

bool stm32_host_reset_requested(void) { return reset_requested; }

/* The SCS model's state (below). */
static struct {
    uint32_t enabled[3]; /* NVIC ISER */
    uint8_t prio[MAX_IRQS];
    uint32_t systick_csr, systick_rvr;
    uint64_t systick_from; /* cycle the counter was (re)loaded at */
    uint64_t systick_seen; /* reloads counted when the last tick was pended */
    uint32_t shpr3, icsr_other;
} scs;

bool stm32_host_irq_enabled(int irqn)
{
    return irqn >= 0 && (scs.enabled[irqn / 32] & (1u << (irqn % 32))) != 0u;
}

uint8_t stm32_host_irq_priority(int irqn) { return scs.prio[irqn]; }

/* The pending interrupt of the highest priority (lowest value), SysTick's
 * from SHPR3; -2 when none. */
static int next_interrupt(void)
{
    int best = -2;
    unsigned best_prio = 256u;
    if (pending[0] && (scs.systick_csr & 0x2u) != 0u && vectors[0] != NULL) {
        best = -1;
        best_prio = scs.shpr3 >> 24;
    }
    for (int n = 0; n < MAX_IRQS; n++) {
        if (pending[slot(n)] && stm32_host_irq_enabled(n) && vectors[slot(n)] != NULL &&
            scs.prio[n] < best_prio) {
            best = n;
            best_prio = scs.prio[n];
        }
    }
    return best;
}

void stm32_host_take_interrupts(void)
{
    if (in_handler) {
        return; /* one level: the models raise, the handlers run one by one */
    }
    int n;
    unsigned storm = 0;
    while (!primask && (n = next_interrupt()) != -2) {
        if (++storm > 100000u) {
            /* A handler that never clears its cause: on a core, a hang. */
            fprintf(stderr, "stm32_host: interrupt %d taken 100000 times in a row\n", n);
            abort();
        }
        pending[slot(n)] = false;
        taken[slot(n)]++;
        in_handler = true;
        handler_accesses = 0u;
        active = n;
        vectors[slot(n)]();
        active = -2;
        in_handler = false;
        for (unsigned i = 0; i < n_levels; i++) {
            levels[i].level(levels[i].ctx);
        }
    }
}

uint32_t stm32_host_irq_save(void)
{
    const uint32_t was = primask ? 1u : 0u;
    primask = true;
    return was;
}

void stm32_host_irq_restore(uint32_t was)
{
    if (was == 0u) {
        primask = false;
        stm32_host_take_interrupts();
    }
}

void stm32_host_irq_enable_all(void)
{
    primask = false;
    stm32_host_take_interrupts();
}

void stm32_host_irq_disable_all(void) { primask = true; }

void stm32_host_wfi(void)
{
    /* Asleep until an interrupt is pending: a millisecond at most (SysTick
     * wakes the boards' cores that often), taken when not masked. */
    const uint64_t per_us = clock_hz / 1000000u;
    for (unsigned i = 0; i < 1000u && next_interrupt() == -2; i++) {
        stm32_host_spend(per_us);
    }
    stm32_host_take_interrupts();
}

void stm32_host_system_reset(void) { reset_requested = true; }

/* ------------------------------------------------------------ the SCS */

#define SCS_BASE  0xE000E000u
#define OFF(addr) ((addr)-SCS_BASE)

/* SysTick counts core cycles down from RVR to 0 and reloads (ARMv7-M ARM
 * B3.3): the current value, and the reloads since it was started. */
static uint64_t systick_reloads(void)
{
    return (cycles - scs.systick_from) / ((uint64_t)scs.systick_rvr + 1u);
}

static void systick_time(void *ctx, uint64_t now)
{
    (void)ctx;
    (void)now;
    if ((scs.systick_csr & 0x1u) == 0u) {
        return;
    }
    const uint64_t r = systick_reloads();
    if (r > scs.systick_seen) {
        scs.systick_seen = r; /* several reloads pend one exception */
        if ((scs.systick_csr & 0x2u) != 0u) {
            pending[0] = true;
        }
    }
}

static uint32_t scs_read(stm32_host_periph_t *p, uint32_t off)
{
    if (off == OFF(0xE000E018u)) { /* SYST_CVR */
        if ((scs.systick_csr & 0x1u) == 0u) {
            return p->reg[off / 4u];
        }
        const uint64_t in = (cycles - scs.systick_from) % ((uint64_t)scs.systick_rvr + 1u);
        return in == 0u ? 0u : scs.systick_rvr + 1u - (uint32_t)in;
    }
    if (off == OFF(0xE000ED04u)) { /* ICSR: PENDSTSET */
        return scs.icsr_other | (pending[0] ? (1u << 26) : 0u);
    }
    if (off == OFF(0xE000E010u)) { /* SYST_CSR */
        return scs.systick_csr;
    }
    if (off == OFF(0xE000E014u)) { /* SYST_RVR */
        return scs.systick_rvr;
    }
    if (off == OFF(0xE000ED20u)) { /* SHPR3 */
        return scs.shpr3;
    }
    if (off >= OFF(0xE000E100u) && off < OFF(0xE000E10Cu)) { /* ISER */
        return scs.enabled[(off - OFF(0xE000E100u)) / 4u];
    }
    if (off >= OFF(0xE000E400u) && off < OFF(0xE000E400u) + MAX_IRQS) { /* IPR */
        const unsigned i = off - OFF(0xE000E400u);
        return (uint32_t)scs.prio[i] | ((uint32_t)scs.prio[i + 1u] << 8) |
               ((uint32_t)scs.prio[i + 2u] << 16) | ((uint32_t)scs.prio[i + 3u] << 24);
    }
    return p->reg[off / 4u];
}

static void scs_write(stm32_host_periph_t *p, uint32_t off, uint32_t v)
{
    if (off >= OFF(0xE000E100u) && off < OFF(0xE000E10Cu)) { /* ISER: write 1 to enable */
        scs.enabled[(off - OFF(0xE000E100u)) / 4u] |= v;
    } else if (off >= OFF(0xE000E180u) && off < OFF(0xE000E18Cu)) { /* ICER */
        scs.enabled[(off - OFF(0xE000E180u)) / 4u] &= ~v;
    } else if (off >= OFF(0xE000E200u) && off < OFF(0xE000E20Cu)) { /* ISPR */
        for (unsigned b = 0; b < 32u; b++) {
            if ((v & (1u << b)) != 0u) {
                pending[slot((int)((off - OFF(0xE000E200u)) * 8u + b))] = true;
            }
        }
    } else if (off >= OFF(0xE000E400u) && off < OFF(0xE000E400u) + MAX_IRQS) { /* IPR */
        const unsigned i = off - OFF(0xE000E400u);
        for (unsigned b = 0; b < 4u; b++) {
            scs.prio[i + b] = (uint8_t)(v >> (8u * b));
        }
    } else if (off == OFF(0xE000E010u)) { /* SYST_CSR */
        const bool start = (v & 0x1u) != 0u && (scs.systick_csr & 0x1u) == 0u;
        scs.systick_csr = v & 0x7u;
        if (start) {
            scs.systick_from = cycles;
            scs.systick_seen = 0u;
        }
    } else if (off == OFF(0xE000E014u)) { /* SYST_RVR: 24 bits */
        scs.systick_rvr = v & 0x00FFFFFFu;
    } else if (off == OFF(0xE000E018u)) { /* SYST_CVR: any write clears it */
        scs.systick_from = cycles;
        scs.systick_seen = 0u;
        p->reg[off / 4u] = 0u;
    } else if (off == OFF(0xE000ED20u)) { /* SHPR3 */
        scs.shpr3 = v;
    } else if (off == OFF(0xE000ED04u)) { /* ICSR: PENDSTCLR */
        if ((v & (1u << 25)) != 0u) {
            pending[0] = false;
        }
    } else {
        p->reg[off / 4u] = v;
    }
}

static stm32_host_periph_t scs_block = {
    .base = SCS_BASE, .size = PAGE, .name = "SCS", .read = scs_read, .write = scs_write
};

void stm32_host_reset(void)
{
    static bool installed;
    if (!installed) {
        struct sigaction sa = { 0 };
        sa.sa_flags = SA_SIGINFO | SA_NODEFER;
        sa.sa_sigaction = on_segv;
        sigaction(SIGSEGV, &sa, NULL);
        sa.sa_sigaction = on_trap;
        sigaction(SIGTRAP, &sa, NULL);
        installed = true;
    }
    for (unsigned i = 0; i < n_blocks; i++) {
        bool first = true;
        for (unsigned k = 0; k < i; k++) {
            first = first && page_of(blocks[k]) != page_of(blocks[i]);
        }
        if (first) {
            munmap(page_of(blocks[i]), PAGE);
        }
    }
    n_blocks = 0u;
    n_tickers = 0u;
    n_levels = 0u;
    active = -2;
    cycles = 0u;
    clock_hz = 168000000u;
    primask = false;
    reset_requested = false;
    in_handler = false;
    memset(vectors, 0, sizeof vectors);
    memset(pending, 0, sizeof pending);
    memset(taken, 0, sizeof taken);
    memset(&scs, 0, sizeof scs);
    memset(scs_block.reg, 0, sizeof scs_block.reg);
    stm32_host_map(&scs_block);
    stm32_host_on_time(systick_time, NULL);
}
