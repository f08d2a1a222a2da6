/* SPDX-License-Identifier: MIT */
/* STM32F103 board: clock tree, GPIO, clocks of the peripherals, reset flags.
 * RM0008 (STM32F101/102/103/105/107 reference manual, Rev 21) sections are
 * cited; register names come from the generated stm32_regs.h. */
#include <stdbool.h>
#include <stdint.h>

#include "board.h"
#include "hal/hal_sys.h"

/* PLL (RM0008 §7.2, §7.3.2): HSE (not divided) × 9 = 72 MHz. AHB /1 = 72 MHz;
 * APB1 /2 = 36 MHz (max 36); APB2 /1 = 72 MHz; ADC /6 = 12 MHz (max 14).
 * Timers on the divided APB1 run at twice its clock: 72 MHz. */
#define PLL_MUL   9u
#define SYSCLK_HZ (BOARD_HSE_HZ * PLL_MUL)
_Static_assert(SYSCLK_HZ == 72000000u, "SYSCLK 72 MHz");
#define CFGR_PLLMUL(m)   (((m)-2u) << RCC_CFGR_PLLMUL_Pos)
#define CFGR_PPRE_DIV2   4u
#define CFGR_ADCPRE_DIV6 2u
#define CFGR_SW_HSI      0u
#define CFGR_SW_PLL      2u

/* Flash: 2 wait states for 48 < SYSCLK <= 72 MHz, prefetch on (RM0008 §3.3.3,
 * PM0075 §3.1). */
#define FLASH_LATENCY_72MHZ 2u

/* Time-outs as loop counts: no timer runs yet (HSE start-up: DS5319 gives
 * 1.5 ms typical). */
#define CLOCK_SPINS 200000u

static board_clocks_t clocks = {
    .sysclk_hz = 8000000u, .apb1_hz = 8000000u, .apb1_tim_hz = 8000000u, .hse = false
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
    RCC->CR |= RCC_CR_HSEON_Msk;
    if (!wait_set(&RCC->CR, RCC_CR_HSERDY_Msk, RCC_CR_HSERDY_Msk)) {
        RCC->CR &= ~RCC_CR_HSEON_Msk; /* no crystal: stay on HSI, 8 MHz */
        return;
    }
    FLASH->ACR = (FLASH->ACR & ~FLASH_ACR_LATENCY_Msk) | FLASH_ACR_PRFTBE_Msk |
                 (FLASH_LATENCY_72MHZ << FLASH_ACR_LATENCY_Pos);
    const uint32_t hsi_cfgr = RCC->CFGR;
    RCC->CFGR = (hsi_cfgr & ~(RCC_CFGR_PLLMUL_Msk | RCC_CFGR_PLLXTPRE_Msk | RCC_CFGR_HPRE_Msk |
                              RCC_CFGR_PPRE1_Msk | RCC_CFGR_PPRE2_Msk | RCC_CFGR_ADCPRE_Msk)) |
                CFGR_PLLMUL(PLL_MUL) | RCC_CFGR_PLLSRC_Msk |
                (CFGR_PPRE_DIV2 << RCC_CFGR_PPRE1_Pos) | (CFGR_ADCPRE_DIV6 << RCC_CFGR_ADCPRE_Pos);
    RCC->CR |= RCC_CR_PLLON_Msk;
    if (!wait_set(&RCC->CR, RCC_CR_PLLRDY_Msk, RCC_CR_PLLRDY_Msk)) {
        RCC->CR &= ~RCC_CR_PLLON_Msk;
        RCC->CFGR = hsi_cfgr;
        return;
    }
    RCC->CFGR = (RCC->CFGR & ~RCC_CFGR_SW_Msk) | (CFGR_SW_PLL << RCC_CFGR_SW_Pos);
    if (!wait_set(&RCC->CFGR, RCC_CFGR_SWS_Msk, CFGR_SW_PLL << RCC_CFGR_SWS_Pos)) {
        RCC->CFGR = hsi_cfgr;
        return;
    }
    clocks = (board_clocks_t){
        .sysclk_hz = SYSCLK_HZ,
        .apb1_hz = SYSCLK_HZ / 2u,
        .apb1_tim_hz = SYSCLK_HZ,
        .hse = true,
    };
}

const board_clocks_t *board_clocks(void) { return &clocks; }

/* GPIO (RM0008 §9.2.1): four bits per pin in CRL (0..7) / CRH (8..15):
 * MODE[1:0] (00 input, 10 output 2 MHz, 11 output 50 MHz), CNF[1:0]. */
#define CFG_OUT_PP_2MHZ 0x2u /* general-purpose push-pull */
#define CFG_AF_PP_2MHZ  0xAu /* alternate push-pull, 2 MHz (20 kHz PWM) */
#define CFG_AF_PP_50MHZ 0xBu /* alternate push-pull, 50 MHz (CAN TX, USART TX) */
#define CFG_IN_PULL     0x8u /* input with pull-up/down, chosen by ODR */

static void pin_cfg(GPIO_TypeDef *port, unsigned pin, uint32_t cfg)
{
    const unsigned s = 4u * (pin & 7u);
    if (pin < 8u) {
        port->CRL = (port->CRL & ~(0xFu << s)) | (cfg << s);
    } else {
        port->CRH = (port->CRH & ~(0xFu << s)) | (cfg << s);
    }
}

static void pin_write(GPIO_TypeDef *port, unsigned pin, bool high)
{
    port->BSRR = high ? (1u << pin) : (1u << (pin + 16u));
}

/* AFIO_MAPR.CAN_REMAP = 10: CAN_RX on PB8, CAN_TX on PB9 (RM0008 §9.3.3). */
#define CAN_REMAP_PB8_PB9 2u

void board_gpio_init(void)
{
    RCC->APB2ENR |= RCC_APB2ENR_IOPAEN_Msk | RCC_APB2ENR_IOPBEN_Msk | RCC_APB2ENR_IOPCEN_Msk |
                    RCC_APB2ENR_AFIOEN_Msk;
    (void)RCC->APB2ENR;
    pin_write(GPIOB, 12u, false); /* driver disabled */
    pin_write(GPIOB, 0u, false);
    pin_write(GPIOB, 1u, false);
    pin_write(GPIOC, 13u, true); /* LED off (active low) */
    pin_cfg(GPIOB, 12u, CFG_OUT_PP_2MHZ);
    pin_cfg(GPIOB, 0u, CFG_OUT_PP_2MHZ);
    pin_cfg(GPIOB, 1u, CFG_OUT_PP_2MHZ);
    pin_cfg(GPIOC, 13u, CFG_OUT_PP_2MHZ);
    pin_cfg(GPIOA, 6u, CFG_AF_PP_2MHZ);
    pin_cfg(GPIOA, 7u, CFG_AF_PP_2MHZ);
    /* MAPR's SWJ_CFG bits read as 0 and writing 0 keeps SWD/JTAG on. */
    AFIO->MAPR =
        (AFIO->MAPR & ~AFIO_MAPR_CAN_REMAP_Msk) | (CAN_REMAP_PB8_PB9 << AFIO_MAPR_CAN_REMAP_Pos);
    pin_write(GPIOB, 8u, true); /* pull-up: RX idles recessive */
    pin_cfg(GPIOB, 8u, CFG_IN_PULL);
    pin_cfg(GPIOB, 9u, CFG_AF_PP_50MHZ);
}

void board_can_enable(void)
{
    RCC->APB1ENR |= RCC_APB1ENR_CANEN_Msk;
    (void)RCC->APB1ENR;
}

void board_slcan_enable(void)
{
    /* USART2 on PA2 (TX) / PA3 (RX) without remap (RM0008 §9.3.8). */
    RCC->APB1ENR |= RCC_APB1ENR_USART2EN_Msk;
    (void)RCC->APB1ENR;
    pin_cfg(GPIOA, 2u, CFG_AF_PP_50MHZ);
    pin_write(GPIOA, 3u, true); /* pull-up: RX idles high with no adapter, too */
    pin_cfg(GPIOA, 3u, CFG_IN_PULL);
}

void board_timers_enable(void)
{
    RCC->APB1ENR |= RCC_APB1ENR_TIM2EN_Msk | RCC_APB1ENR_TIM3EN_Msk;
    (void)RCC->APB1ENR;
}

/* Encoder inputs: the timers read the pins as inputs (RM0008 §9.1.11),
 * pulled up (open-collector encoders work without resistors of their own). */
static void encoder_pin(GPIO_TypeDef *port, unsigned pin)
{
    pin_write(port, pin, true);
    pin_cfg(port, pin, CFG_IN_PULL);
}

void board_encoder_enable(void)
{
    RCC->APB1ENR |= RCC_APB1ENR_TIM4EN_Msk;
    RCC->APB2ENR |= RCC_APB2ENR_TIM1EN_Msk;
    (void)RCC->APB2ENR;
    encoder_pin(GPIOB, 6u);
    encoder_pin(GPIOB, 7u);
    encoder_pin(GPIOA, 8u);
    encoder_pin(GPIOA, 9u);
}

void board_led(bool on) { pin_write(GPIOC, 13u, !on); }

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
        RCC->CSR |= RCC_CSR_RMVF_Msk;
        read = true;
    }
    return flags;
}

int hal_sys_boot_nonce(uint32_t *nonce)
{
    /* No TRNG on the F1. A 32-bit counter in backup registers DR1 (high
     * half) and DR2 (low half), one more at every call: the backup domain
     * keeps it across every reset (pin, watchdog, software, brown-out) while
     * VDD or VBAT is present, and loses it when both go (RM0008 5.1). Writes
     * need the backup domain unlocked (PWR_CR DBP). */
    RCC->APB1ENR |= RCC_APB1ENR_PWREN_Msk | RCC_APB1ENR_BKPEN_Msk;
    PWR->CR |= PWR_CR_DBP_Msk;
    const uint32_t n = (((BKP->DR1 & 0xFFFFu) << 16) | (BKP->DR2 & 0xFFFFu)) + 1u;
    BKP->DR1 = n >> 16;
    BKP->DR2 = n & 0xFFFFu;
    PWR->CR &= ~PWR_CR_DBP_Msk;
    *nonce = n;
    return 0;
}

void board_debug_init(void)
{
    /* RM0008 §31.16.3: keep the debug port clocked in sleep; stop the
     * watchdog and the control timer while halted (not the PWM timer). */
    DBG->CR |= DBGMCU_CR_DBG_SLEEP_Msk | DBGMCU_CR_DBG_IWDG_STOP_Msk | DBGMCU_CR_DBG_TIM2_STOP_Msk;
}
