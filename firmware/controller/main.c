/* 6-axis serial controller, ATmega328P at 16 MHz (Arduino Nano). Six pots on ADC0..5, five
 * buttons on PD2..PD6, frames to the host over the UART (the Nano's USB bridge). PD0/PD1 are the
 * UART; PD6 (OC0A, AIN0) is free: timer 0 and the analog comparator are not used.
 * Hardware glue only: protocol, filtering, calibration and scheduling live in ../common. */
#include <avr/eeprom.h>
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>
#include <avr/wdt.h>
#include <util/atomic.h>

#include <string.h>

#include "axis.h"
#include "calib.h"
#include "debounce.h"
#include "proto.h"
#include "sched.h"

#include "config.h"

/* ---- reset cause, captured before anything else runs ---- */

/* .noinit: the C runtime must not clear it after .init3 has written it. */
static uint8_t reset_flags __attribute__((section(".noinit")));

/* After a watchdog reset the watchdog stays enabled at its shortest timeout, so it has to be
 * switched off before the C runtime's initialisation could outlast it. */
void early_init(void) __attribute__((naked, used, section(".init3")));
void early_init(void)
{
    uint8_t flags = MCUSR;
    MCUSR = 0;
    wdt_disable();
    if (!flags) {
        /* Optiboot clears MCUSR and hands its old value over in r2. */
        __asm__ volatile("mov %0, r2" : "=r"(flags));
        flags &= 0x0F;
    }
    reset_flags = flags;
}

/* ---- UART: interrupt driven both ways, so sending never stalls the sampling ---- */

#define TX_SIZE 128 /* power of two; a tick sends at most two frames (< 2 x PROTO_MAX_WIRE) */
#define RX_SIZE 32
static volatile uint8_t tx_buf[TX_SIZE], tx_head, tx_tail;
static volatile uint8_t rx_buf[RX_SIZE], rx_head, rx_tail;

static void uart_init(void)
{
    /* U2X: 115200 from 16 MHz is 2.1 % off; without it 3.5 %. */
    UCSR0A = _BV(U2X0);
    UBRR0 = (uint16_t)((F_CPU + 4 * BAUD) / (8 * BAUD) - 1);
    UCSR0C = _BV(UCSZ01) | _BV(UCSZ00); /* 8N1 */
    UCSR0B = _BV(RXEN0) | _BV(TXEN0) | _BV(RXCIE0);
}

ISR(USART_UDRE_vect)
{
    if (tx_head == tx_tail) {
        UCSR0B &= (uint8_t)~_BV(UDRIE0);
        return;
    }
    UDR0 = tx_buf[tx_tail];
    tx_tail = (tx_tail + 1) & (TX_SIZE - 1);
}

ISR(USART_RX_vect)
{
    uint8_t b = UDR0;
    uint8_t next = (rx_head + 1) & (RX_SIZE - 1);
    if (next != rx_tail) { /* full: drop; the frame's CRC fails and the host retries */
        rx_buf[rx_head] = b;
        rx_head = next;
    }
}

static void uart_write(const uint8_t *p, uint8_t n)
{
    while (n--) {
        uint8_t next = (tx_head + 1) & (TX_SIZE - 1);
        while (next == tx_tail)
            ; /* only if the host side stalls the line; the watchdog bounds it */
        tx_buf[tx_head] = *p++;
        tx_head = next;
        UCSR0B |= _BV(UDRIE0);
    }
}

static int uart_read(uint8_t *b)
{
    if (rx_head == rx_tail)
        return 0;
    *b = rx_buf[rx_tail];
    rx_tail = (rx_tail + 1) & (RX_SIZE - 1);
    return 1;
}

/* ---- 1 kHz timer: uptime, button debouncing, the 100 Hz tick ---- */

static volatile uint32_t uptime_ms;
static volatile uint8_t tick_due;
static volatile uint8_t buttons;
static struct debounce button_db;

static void timer_init(void)
{
    TCCR1A = 0;
    TCCR1B = _BV(WGM12) | _BV(CS11) | _BV(CS10); /* CTC, clk/64 */
    OCR1A = F_CPU / 64 / 1000 - 1;
    TIMSK1 = _BV(OCIE1A);
}

ISR(TIMER1_COMPA_vect)
{
    static uint8_t sub;
    uptime_ms++;
    uint8_t raw = (uint8_t)(~PIND >> BUTTON_SHIFT) & ((1u << N_BUTTONS) - 1);
    buttons = debounce_step(&button_db, raw);
    if (++sub >= TICK_MS) {
        sub = 0;
        tick_due = 1;
    }
}

static uint32_t now_ms(void)
{
    uint32_t t;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { t = uptime_ms; }
    return t;
}

/* ---- ADC ---- */

static void adc_init(void)
{
    ADMUX = _BV(REFS0);                                /* AVcc reference */
    ADCSRA = _BV(ADEN) | _BV(ADPS2) | _BV(ADPS1) | _BV(ADPS0); /* 125 kHz */
    DIDR0 = 0x3F;                                      /* no digital buffers on ADC0..5 */
}

static uint16_t adc_convert(void)
{
    ADCSRA |= _BV(ADSC);
    while (ADCSRA & _BV(ADSC))
        ;
    return ADC;
}

/* One reading in c16 (1/16 count): OVERSAMPLE conversions summed, scaled to 16x. */
static uint16_t adc_read_c16(uint8_t ch)
{
    uint16_t sum = 0;
    ADMUX = _BV(REFS0) | ch;
    (void)adc_convert(); /* the sample-and-hold needs one conversion to settle after the mux */
    for (uint8_t i = 0; i < OVERSAMPLE; i++)
        sum += adc_convert();
    return (uint16_t)(sum * (16 / OVERSAMPLE));
}

/* ---- the controller ---- */

static uint8_t seq;
static struct proto_rx rx;
static struct axis_filter filters[PROTO_AXES_N];
static uint16_t filtered[PROTO_AXES_N];
static uint16_t zero[PROTO_AXES_N];
static const struct axis_cfg axis_cfg = { DEADZONE_C16, EDGE_C16 };
static uint8_t EEMEM ee_calib[CALIB_RECORD_SIZE];

static void send(uint8_t type, const uint8_t *payload, uint8_t len)
{
    uint8_t wire[PROTO_MAX_WIRE];
    uint8_t n = (uint8_t)proto_frame(type, seq++, payload, len, wire);
    uart_write(wire, n);
}

static void send_hello(void)
{
    struct proto_hello h = {
        FW_VERSION_MAJOR, FW_VERSION_MINOR, FW_VERSION_PATCH, BOARD_ID,
        PROTO_AXES_N, N_BUTTONS, FRAME_HZ, HEARTBEAT_MS, reset_flags,
    };
    uint8_t p[PROTO_HELLO_LEN];
    send(PROTO_HELLO, p, (uint8_t)proto_pack_hello(p, &h));
}

static void send_calibration(uint8_t reason, uint8_t eeprom_mask)
{
    struct proto_calibration c;
    uint8_t p[PROTO_CALIBRATION_LEN];
    c.reason = reason;
    c.eeprom_mask = eeprom_mask;
    memcpy(c.zero, zero, sizeof zero);
    send(PROTO_CALIBRATION, p, (uint8_t)proto_pack_calibration(p, &c));
}

static void sample_axes(void)
{
    for (uint8_t i = 0; i < PROTO_AXES_N; i++)
        filtered[i] = axis_filter_step(&filters[i], adc_read_c16(i));
}

static void calibrate_now(uint8_t reason)
{
    uint8_t rec[CALIB_RECORD_SIZE];
    memcpy(zero, filtered, sizeof zero);
    calib_pack(zero, rec);
    wdt_reset(); /* the write takes up to ~60 ms */
    eeprom_update_block(rec, ee_calib, sizeof rec); /* rewrites only bytes that changed */
    send_calibration(reason, 0);
}

/* Sleeps until the next 100 Hz tick; the UART and timers keep running in idle mode. */
static void wait_tick(void)
{
    set_sleep_mode(SLEEP_MODE_IDLE);
    cli();
    while (!tick_due) {
        sleep_enable();
        sei();
        sleep_cpu(); /* sei's one-instruction delay: no wake-up is lost in between */
        sleep_disable();
        cli();
    }
    tick_due = 0;
    sei();
}

static void power_up_calibration(void)
{
    uint32_t sum[PROTO_AXES_N] = { 0 };
    uint16_t measured[PROTO_AXES_N], stored[PROTO_AXES_N];
    uint8_t rec[CALIB_RECORD_SIZE];

    for (uint8_t t = 0; t < CAL_BOOT_TICKS; t++) {
        wait_tick();
        wdt_reset();
        sample_axes();
        for (uint8_t i = 0; i < PROTO_AXES_N; i++)
            sum[i] += filtered[i];
    }
    for (uint8_t i = 0; i < PROTO_AXES_N; i++)
        measured[i] = (uint16_t)((sum[i] + CAL_BOOT_TICKS / 2) / CAL_BOOT_TICKS);
    eeprom_read_block(rec, ee_calib, sizeof rec);
    int valid = calib_unpack(rec, stored);
    uint8_t kept = calib_choose(measured, valid ? stored : 0, CAL_TOLERANCE_C16, zero);
    send_calibration(PROTO_CAL_POWER_UP, kept);
}

static void handle_command(const struct proto_msg *m)
{
    switch (m->type) {
    case PROTO_HELLO_REQUEST:
        send_hello();
        break;
    case PROTO_CALIBRATE:
        calibrate_now(PROTO_CAL_HOST);
        break;
    case PROTO_WATCHDOG_TEST:
        if (memcmp(m->payload, PROTO_WATCHDOG_KEY, PROTO_WATCHDOG_TEST_LEN) == 0) {
            /* Hang the way a bug would (interrupts still drain the UART): the watchdog must
             * bring the board back. */
            for (;;)
                ;
        }
        break;
    default:
        break; /* device-to-host types echoed back, e.g. by a loopback: ignore */
    }
}

int main(void)
{
    static struct sched sched;
    static struct calib_gesture gesture;

    wdt_enable(WDTO_250MS);
    PORTD |= (uint8_t)(((1u << N_BUTTONS) - 1) << BUTTON_SHIFT); /* pull-ups */
    debounce_init(&button_db, DEBOUNCE_MS, 0);
    for (uint8_t i = 0; i < PROTO_AXES_N; i++)
        axis_filter_init(&filters[i], FILTER_SHIFT);
    proto_rx_init(&rx);
    sched_init(&sched, LINGER_MS / TICK_MS, HEARTBEAT_MS / TICK_MS);
    calib_gesture_init(&gesture);
    uart_init();
    timer_init();
    adc_init();
    sei();

    /* A lone delimiter ends whatever partial frame the host saw before this reset. */
    static const uint8_t delim = 0x00;
    uart_write(&delim, 1);
    send_hello();
    power_up_calibration();

    for (;;) {
        wait_tick();
        wdt_reset();

        uint8_t b;
        struct proto_msg msg;
        while (uart_read(&b))
            if (proto_rx_byte(&rx, b, &msg))
                handle_command(&msg);

        sample_axes();
        uint8_t btn = buttons;
        if (calib_gesture_step(&gesture, btn, GESTURE_MASK, GESTURE_MS / TICK_MS))
            calibrate_now(PROTO_CAL_BUTTONS);

        struct proto_axes a;
        int active = btn != 0;
        a.t_ms = (uint16_t)now_ms();
        a.buttons = btn;
        for (uint8_t i = 0; i < PROTO_AXES_N; i++) {
            a.axis[i] = axis_scale(filtered[i], zero[i], &axis_cfg);
            active |= a.axis[i] != 0;
        }

        uint8_t p[PROTO_AXES_LEN > PROTO_HEARTBEAT_LEN ? PROTO_AXES_LEN : PROTO_HEARTBEAT_LEN];
        switch (sched_tick(&sched, active)) {
        case SCHED_AXES:
            send(PROTO_AXES, p, (uint8_t)proto_pack_axes(p, &a));
            break;
        case SCHED_HEARTBEAT: {
            struct proto_heartbeat h = { now_ms(), rx.frames_ok, rx.rejected };
            send(PROTO_HEARTBEAT, p, (uint8_t)proto_pack_heartbeat(p, &h));
            break;
        }
        default:
            break;
        }
    }
}
