/* SPDX-License-Identifier: MIT */
/* STM32F405 board: clock tree, GPIO, clocks of the peripherals, reset flags.
 * RM0090 (STM32F405/415/407/417/427/437/429/439 reference manual, Rev 19)
 * sections are cited; register names come from the generated stm32_regs.h. */
#include <errno.h>
#include <stdbool.h>
#include <stdint.h>

#include "board.h"
#include "hal/hal_sys.h"

/* PLL (RM0090 §7.2.3, §7.3.2): VCO input HSE / M = 2 MHz (the value RM0090
 * recommends to limit jitter), VCO = 2 MHz × N = 336 MHz (100..432), SYSCLK =
 * VCO / P = 168 MHz, 48 MHz clock = VCO / Q = 48 MHz (USB, SDIO, RNG). */
#define PLL_M     4u
#define PLL_N     168u
#define PLL_P     2u
#define PLL_Q     7u
#define SYSCLK_HZ (BOARD_HSE_HZ / PLL_M * PLL_N / PLL_P)
_Static_assert(BOARD_HSE_HZ / PLL_M == 2000000u, "VCO input 2 MHz");
_Static_assert(SYSCLK_HZ == 168000000u, "SYSCLK 168 MHz");
_Static_assert(BOARD_HSE_HZ / PLL_M * PLL_N / PLL_Q == 48000000u, "48 MHz clock");

/* AHB /1 = 168 MHz; APB1 /4 = 42 MHz (max 42); APB2 /2 = 84 MHz (max 84).
 * Timers on a divided APB run at twice its clock (RM0090 §7.2). */
#define CFGR_HPRE_DIV1 0u
#define CFGR_PPRE_DIV2 4u
#define CFGR_PPRE_DIV4 5u
#define CFGR_SW_HSI    0u
#define CFGR_SW_PLL    2u

/* Flash wait states at 168 MHz and 2.7..3.6 V: 5 (RM0090 §3.5.1, Table 10). */
#define FLASH_LATENCY_168MHZ 5u

/* Time-outs as loop counts: no timer runs yet. At 16 MHz (HSI) a count is a
 * few cycles: 200 000 counts are well over the HSE start-up time (2 ms typ.,
 * DS8626) and the PLL lock time (~100 µs). */
#define CLOCK_SPINS 200000u

static board_clocks_t clocks = {
    .sysclk_hz = 16000000u, .apb1_hz = 16000000u, .apb1_tim_hz = 16000000u, .hse = false
};

static bool wait_set(volatile uint32_t *reg, uint32_t mask, uint32_t want)
{
    for (uint32_t i = 0; i < CLOCK_SPINS; i++) {
        if ((*reg & mask) == want) {
            return true;
        }
    }
    return false;
}

void board_clock_init(void)
{
    /* HSE on (RM0090 §7.3.1). Without a crystal: stay on HSI. */
    RCC->CR |= RCC_CR_HSEON_Msk;
    if (!wait_set(&RCC->CR, RCC_CR_HSERDY_Msk, RCC_CR_HSERDY_Msk)) {
        RCC->CR &= ~RCC_CR_HSEON_Msk;
        return;
    }
    /* Voltage scale 1, needed above 144 MHz (RM0090 §5.4.1). */
    RCC->APB1ENR |= RCC_APB1ENR_PWREN_Msk;
    (void)RCC->APB1ENR; /* the enable takes effect before PWR is written */
    PWR->CR |= PWR_CR_VOS_Msk;
    /* Wait states before the clock rises; read back as RM0090 §3.5.1 asks. */
    FLASH->ACR = (FLASH_LATENCY_168MHZ << FLASH_ACR_LATENCY_Pos) | FLASH_ACR_PRFTEN_Msk |
                 FLASH_ACR_ICEN_Msk | FLASH_ACR_DCEN_Msk;
    if ((FLASH->ACR & FLASH_ACR_LATENCY_Msk) != (FLASH_LATENCY_168MHZ << FLASH_ACR_LATENCY_Pos)) {
        return;
    }
    RCC->PLLCFGR = (PLL_M << RCC_PLLCFGR_PLLM_Pos) | (PLL_N << RCC_PLLCFGR_PLLN_Pos) |
                   ((PLL_P / 2u - 1u) << RCC_PLLCFGR_PLLP_Pos) | RCC_PLLCFGR_PLLSRC_Msk |
                   (PLL_Q << RCC_PLLCFGR_PLLQ_Pos);
    RCC->CR |= RCC_CR_PLLON_Msk;
    if (!wait_set(&RCC->CR, RCC_CR_PLLRDY_Msk, RCC_CR_PLLRDY_Msk)) {
        RCC->CR &= ~RCC_CR_PLLON_Msk;
        return;
    }
    /* Bus prescalers before the switch, so no bus ever runs too fast. */
    const uint32_t bus_msk = RCC_CFGR_HPRE_Msk | RCC_CFGR_PPRE1_Msk | RCC_CFGR_PPRE2_Msk;
    const uint32_t hsi_cfgr = RCC->CFGR;
    RCC->CFGR = (hsi_cfgr & ~bus_msk) | (CFGR_HPRE_DIV1 << RCC_CFGR_HPRE_Pos) |
                (CFGR_PPRE_DIV4 << RCC_CFGR_PPRE1_Pos) | (CFGR_PPRE_DIV2 << RCC_CFGR_PPRE2_Pos);
    RCC->CFGR = (RCC->CFGR & ~RCC_CFGR_SW_Msk) | (CFGR_SW_PLL << RCC_CFGR_SW_Pos);
    if (!wait_set(&RCC->CFGR, RCC_CFGR_SWS_Msk, CFGR_SW_PLL << RCC_CFGR_SWS_Pos)) {
        RCC->CFGR = (hsi_cfgr & ~RCC_CFGR_SW_Msk) | (CFGR_SW_HSI << RCC_CFGR_SW_Pos);
        return;
    }
    clocks = (board_clocks_t){
        .sysclk_hz = SYSCLK_HZ,
        .apb1_hz = SYSCLK_HZ / 4u,
        .apb1_tim_hz = SYSCLK_HZ / 2u,
        .hse = true,
    };
}

const board_clocks_t *board_clocks(void) { return &clocks; }

/* GPIO (RM0090 §8.4): 2-bit MODER, OSPEEDR and PUPDR fields, 4-bit AF. */
enum { MODE_IN = 0u, MODE_OUT = 1u, MODE_AF = 2u };
enum { SPEED_LOW = 0u, SPEED_HIGH = 2u };
enum { PULL_NONE = 0u, PULL_UP = 1u };

static void pin_mode(GPIO_TypeDef *port, unsigned pin, uint32_t mode, uint32_t speed, uint32_t pull)
{
    const unsigned s = 2u * pin;
    port->OSPEEDR = (port->OSPEEDR & ~(3u << s)) | (speed << s);
    port->PUPDR = (port->PUPDR & ~(3u << s)) | (pull << s);
    port->MODER = (port->MODER & ~(3u << s)) | (mode << s);
}

static void pin_af(GPIO_TypeDef *port, unsigned pin, uint32_t af)
{
    const unsigned s = 4u * (pin & 7u);
    if (pin < 8u) {
        port->AFRL = (port->AFRL & ~(0xFu << s)) | (af << s);
    } else {
        port->AFRH = (port->AFRH & ~(0xFu << s)) | (af << s);
    }
    pin_mode(port, pin, MODE_AF, SPEED_HIGH, PULL_NONE);
}

static void pin_write(GPIO_TypeDef *port, unsigned pin, bool high)
{
    port->BSRR = high ? (1u << pin) : (1u << (pin + 16u)); /* atomic set/reset */
}

#define AF_TIM3   2u
#define AF_TIM4   2u
#define AF_TIM5   2u
#define AF_USART2 7u
#define AF_CAN1   9u

void board_gpio_init(void)
{
    RCC->AHB1ENR |= RCC_AHB1ENR_GPIOAEN_Msk | RCC_AHB1ENR_GPIOBEN_Msk | RCC_AHB1ENR_GPIOCEN_Msk;
    (void)RCC->AHB1ENR;
    /* Levels first, then outputs: nothing glitches high. */
    pin_write(GPIOB, 12u, false); /* driver disabled */
    pin_write(GPIOB, 0u, false);
    pin_write(GPIOB, 1u, false);
    pin_write(GPIOB, 5u, false); /* LED off */
    pin_mode(GPIOB, 12u, MODE_OUT, SPEED_LOW, PULL_NONE);
    pin_mode(GPIOB, 0u, MODE_OUT, SPEED_LOW, PULL_NONE);
    pin_mode(GPIOB, 1u, MODE_OUT, SPEED_LOW, PULL_NONE);
    pin_mode(GPIOB, 5u, MODE_OUT, SPEED_LOW, PULL_NONE);
    /* PWM: the timer's outputs are low until hal_motor_init() enables them. */
    pin_af(GPIOA, 6u, AF_TIM3);
    pin_af(GPIOA, 7u, AF_TIM3);
    pin_af(GPIOB, 8u, AF_CAN1);
    pin_af(GPIOB, 9u, AF_CAN1);
    /* RX idles recessive (high) without a transceiver too. */
    pin_mode(GPIOB, 8u, MODE_AF, SPEED_HIGH, PULL_UP);
}

void board_can_enable(void)
{
    RCC->APB1ENR |= RCC_APB1ENR_CAN1EN_Msk;
    (void)RCC->APB1ENR;
}

void board_slcan_enable(void)
{
    RCC->APB1ENR |= RCC_APB1ENR_USART2EN_Msk;
    (void)RCC->APB1ENR;
    pin_af(GPIOA, 2u, AF_USART2);
    pin_af(GPIOA, 3u, AF_USART2);
    /* RX idles high (stop level) with no adapter plugged in, too. */
    pin_mode(GPIOA, 3u, MODE_AF, SPEED_HIGH, PULL_UP);
}

void board_timers_enable(void)
{
    RCC->APB1ENR |= RCC_APB1ENR_TIM2EN_Msk | RCC_APB1ENR_TIM3EN_Msk;
    (void)RCC->APB1ENR;
}

/* Encoder inputs: alternate function, pulled up (open-collector encoders
 * work without resistors of their own). */
static void encoder_pin(GPIO_TypeDef *port, unsigned pin, uint32_t af)
{
    pin_af(port, pin, af);
    pin_mode(port, pin, MODE_AF, SPEED_LOW, PULL_UP);
}

void board_encoder_enable(void)
{
    RCC->APB1ENR |= RCC_APB1ENR_TIM4EN_Msk | RCC_APB1ENR_TIM5EN_Msk;
    (void)RCC->APB1ENR;
    encoder_pin(GPIOB, 6u, AF_TIM4);
    encoder_pin(GPIOB, 7u, AF_TIM4);
    encoder_pin(GPIOA, 0u, AF_TIM5);
    encoder_pin(GPIOA, 1u, AF_TIM5);
}

void board_led(bool on) { pin_write(GPIOB, 5u, on); }

void board_motor_dir(unsigned wheel, bool forward)
{
    pin_write(GPIOB, wheel == 0u ? 0u : 1u, forward);
}

void board_motor_enable(bool on) { pin_write(GPIOB, 12u, on); }

uint32_t board_reset_flags(void)
{
    static bool read;
    static uint32_t flags;
    if (!read) {
        flags = RCC->CSR;
        RCC->CSR |= RCC_CSR_RMVF_Msk; /* clear, so the next reset tells its own cause */
        read = true;
    }
    return flags;
}

/* Reads of the status register the TRNG may take to give two values: one
 * comes every 40 periods of its 48 MHz clock (RM0090 24.3), under 1 µs. */
#define RNG_POLLS 4000u

int hal_sys_boot_nonce(uint32_t *nonce)
{
    RCC->AHB2ENR |= RCC_AHB2ENR_RNGEN_Msk;
    RNG->CR |= RNG_CR_RNGEN_Msk;
    /* RM0090 24.3.1: each value is compared with the one before and used
     * only when it differs (FIPS PUB 140-2's continuous test); a clock or
     * seed error (CECS, SECS) means no value. A TRNG that never gets ready
     * (no 48 MHz clock; QEMU, which does not model it) gives -EIO. */
    unsigned got = 0u;
    for (unsigned i = 0; i < RNG_POLLS; i++) {
        const uint32_t sr = RNG->SR;
        if ((sr & (RNG_SR_CECS_Msk | RNG_SR_SECS_Msk)) != 0u) {
            break;
        }
        if ((sr & RNG_SR_DRDY_Msk) != 0u) {
            const uint32_t v = RNG->DR;
            if (got > 0u && v != *nonce) {
                *nonce = v;
                return 0;
            }
            *nonce = v;
            got++;
        }
    }
    return -EIO;
}

void board_debug_init(void)
{
    /* Sleep keeps the debug port clocked (WFI in the main loop); the
     * watchdog and the control timer stop while the core is halted. The PWM
     * timer does not: a halted core leaves the wheels at their last duty. */
    DBG->CR |= DBGMCU_CR_DBG_SLEEP_Msk;
    DBG->APB1_FZ |= DBGMCU_APB1_FZ_DBG_IWDG_STOP_Msk | DBGMCU_APB1_FZ_DBG_TIM2_STOP_Msk;
}
