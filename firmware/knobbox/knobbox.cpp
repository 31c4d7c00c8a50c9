/* 7-knob USB HID box, ATmega32U4 at 16 MHz (Arduino Micro), on Debian's Arduino AVR core with
 * CDC disabled: the board enumerates as one vendor-defined HID interface and nothing else.
 * Encoders are scanned at 2 kHz from Timer3; decoding and the report live in ../common. */
#include <Arduino.h>
#include <HID.h>
#include <avr/wdt.h>
#include <util/atomic.h>

extern "C" {
#include "debounce.h"
#include "knob_report.h"
#include "quad.h"
}

#include "pins.h"

static const uint8_t hid_descriptor[] PROGMEM = { KNOB_HID_DESCRIPTOR_BYTES };

/* After a watchdog reset the watchdog stays on at its shortest timeout: switch it off before
 * the C runtime and the Arduino core's init() could outlast it. */
extern "C" void early_init(void) __attribute__((naked, used, section(".init3")));
extern "C" void early_init(void)
{
    MCUSR = 0;
    wdt_disable();
}

static struct quad knobs[KNOB_N];
static struct debounce button_db;
static volatile uint8_t counts[KNOB_N];
static volatile uint8_t buttons;
static struct knob_report report;

ISR(TIMER3_COMPA_vect)
{
    /* One snapshot of every port, so A and B of a knob are sampled at the same instant. */
    const uint8_t pb = PINB, pc = PINC, pd = PIND, pf = PINF;
    const uint8_t port[4] = { pb, pc, pd, pf };

    for (uint8_t i = 0; i < KNOB_N; i++) {
        const struct knob_pins *k = &KNOB_PINS[i];
        /* Contacts close to ground through the pull-ups: invert so "closed" reads 1. */
        uint8_t a = !(port[k->port] & k->a), b = !(port[k->port] & k->b);
        quad_update(&knobs[i], (uint8_t)(a << 1 | b));
        counts[i] = knobs[i].count;
    }
    uint8_t raw = 0;
    for (uint8_t i = 0; i < KNOB_N; i++)
        if (!(port[BUTTON_PINS[i].port] & BUTTON_PINS[i].bit))
            raw |= (uint8_t)(1u << i);
    buttons = debounce_step(&button_db, raw);
}

static void read_state(uint8_t c[KNOB_N], uint8_t *b)
{
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE)
    {
        for (uint8_t i = 0; i < KNOB_N; i++)
            c[i] = counts[i];
        *b = buttons;
    }
}

void setup()
{
    static HIDSubDescriptor node(hid_descriptor, sizeof hid_descriptor);
    HID().AppendDescriptor(&node);

    /* PF4..PF7 are JTAG pins unless JTAG is off; JTD must be written twice within 4 cycles. */
    MCUCR = _BV(JTD);
    MCUCR = _BV(JTD);
    pins_init();

    const uint8_t port[4] = { PINB, PINC, PIND, PINF };
    for (uint8_t i = 0; i < KNOB_N; i++) {
        const struct knob_pins *k = &KNOB_PINS[i];
        uint8_t a = !(port[k->port] & k->a), b = !(port[k->port] & k->b);
        quad_init(&knobs[i], (uint8_t)(a << 1 | b), STEPS_PER_DETENT);
    }
    debounce_init(&button_db, DEBOUNCE_SAMPLES, 0);
    uint8_t c[KNOB_N] = { 0 };
    knob_report_init(&report, c, 0);

    /* Timer3, CTC, clk/8: 2 kHz. Fast enough for a flicked 24-detent knob (~500 steps/s). */
    TCCR3A = 0;
    TCCR3B = _BV(WGM32) | _BV(CS31);
    OCR3A = F_CPU / 8 / SCAN_HZ - 1;
    TIMSK3 = _BV(OCIE3A);

    wdt_enable(WDTO_1S); /* above USB_Send's own 250 ms timeout when the host stops polling */
}

void loop()
{
    static bool was_configured;
    uint8_t c[KNOB_N], b, out[KNOB_REPORT_SIZE];

    wdt_reset();
    read_state(c, &b);

    bool configured = USBDevice.configured();
    /* After (re-)enumeration send the current buttons at once, even if nothing moved. */
    int force = configured && !was_configured;
    was_configured = configured;
    if (!configured)
        return; /* counts keep accumulating; the first report after enumeration carries them */

    if (knob_report_build(&report, c, b, force, out))
        HID().SendReport(out[0], out + 1, KNOB_REPORT_SIZE - 1);
}
