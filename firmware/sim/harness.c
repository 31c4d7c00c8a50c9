/* Runs an AVR firmware in simavr with its UART bridged to a pseudo-terminal, so a host program
 * opens the pty as it would open the real board's serial port.
 *
 *   harness [--mcu atmega328p] [--freq 16000000] [--vcc 5000] [--speed X] FIRMWARE.elf
 *
 * Prints "pty PATH" once the pty exists, then obeys lines on stdin, answering each with
 * "ok ..." (or "error ...") once it has taken effect:
 *   adc CH MV          drive ADC channel CH with MV millivolts
 *   pin PORT BIT LEVEL drive an input pin (e.g. "pin D 2 0": a button on PD2 pressed)
 *   run                start the CPU (it waits, so the host can open the pty first)
 *   time               report the simulated time: "ok time US"
 *   quit
 * and reports a CPU reset (watchdog, ...) with a line "reset at US" (simulated time) whenever it happens.
 * --speed X paces simulated time at X times real time (0: as fast as possible). Bytes the
 * firmware sends while nobody reads the pty are dropped, as on a real line. */
#define _GNU_SOURCE
#include <errno.h>
#include <stdarg.h>
#include <fcntl.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#include "avr_adc.h"
#include "avr_ioport.h"
#include "avr_uart.h"
#include "sim_avr.h"
#include "sim_elf.h"
#include "sim_irq.h"

static avr_t *avr;
static int master_fd = -1;
static double sim_seconds(void);
static double speed = 1.0;
static int running, quitting;

/* ---- UART <-> pty ---- */

static uint8_t in_buf[4096];
static size_t in_len, in_pos;
static int uart_xon = 1;
static avr_irq_t *uart_in_irq;

static void uart_out_hook(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq, (void)param;
    uint8_t b = (uint8_t)value;
    /* Non-blocking: with nobody reading, the pty fills and bytes are lost, like on a wire. */
    static int dropping;
    if (write(master_fd, &b, 1) == 1) {
        dropping = 0;
    } else if (errno != EAGAIN) {
        perror("harness: pty write");
    } else if (!dropping) {
        dropping = 1; /* once per burst: the log says where a reader fell behind */
        fprintf(stderr, "harness: pty full, dropping bytes at %.3f s\n", sim_seconds());
    }
}

static void uart_xon_hook(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq, (void)value, (void)param;
    uart_xon = 1;
}

static void uart_xoff_hook(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq, (void)value, (void)param;
    uart_xon = 0;
}

/* Hands queued host bytes to the UART while its receive FIFO has room. */
static void feed_uart(void)
{
    while (uart_xon && in_pos < in_len)
        avr_raise_irq(uart_in_irq, in_buf[in_pos++]);
    if (in_pos == in_len)
        in_pos = in_len = 0;
}

static void read_pty(void)
{
    if (in_len == sizeof in_buf)
        return;
    ssize_t n = read(master_fd, in_buf + in_len, sizeof in_buf - in_len);
    if (n > 0)
        in_len += (size_t)n;
}

static void uart_connect(void)
{
    uint32_t flags = 0;
    avr_ioctl(avr, AVR_IOCTL_UART_GET_FLAGS('0'), &flags);
    /* No console echo of firmware output, no usleep when the firmware polls the UART. */
    flags &= ~(uint32_t)(AVR_UART_FLAG_STDIO | AVR_UART_FLAG_POLL_SLEEP);
    avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);

    uart_in_irq = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT),
                            uart_out_hook, NULL);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XON),
                            uart_xon_hook, NULL);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XOFF),
                            uart_xoff_hook, NULL);
}

static int open_pty(char *path, size_t cap)
{
    master_fd = posix_openpt(O_RDWR | O_NOCTTY);
    if (master_fd < 0 || grantpt(master_fd) || unlockpt(master_fd))
        return -1;
    if (ptsname_r(master_fd, path, cap))
        return -1;
    /* Keep a slave fd open for the harness's lifetime: the line settings stay raw (no echo of
     * firmware bytes back into the UART, no newline mangling) and the master never sees EIO
     * while the host has the port closed. */
    int slave = open(path, O_RDWR | O_NOCTTY);
    if (slave < 0)
        return -1;
    struct termios t;
    if (tcgetattr(slave, &t))
        return -1;
    cfmakeraw(&t);
    if (tcsetattr(slave, TCSANOW, &t))
        return -1;
    return fcntl(master_fd, F_SETFL, fcntl(master_fd, F_GETFL) | O_NONBLOCK);
}

/* ---- commands on stdin ---- */

static char cmd_buf[256];
static size_t cmd_len;
static FILE *out; /* replies; simavr's own printf chatter is sent to stderr */

static void reply(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
static void reply(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vfprintf(out, fmt, ap);
    va_end(ap);
    fputc('\n', out);
    fflush(out);
}

static uint8_t ext_mask[26], ext_value[26];

/* simavr clears the PIN registers on reset but keeps each pin IRQ's last value, so raising the
 * same level again is filtered out and a released button would read as pressed. Re-drive every
 * pin the host set, through the opposite level, before the firmware runs again. */
static void redrive_pins(void)
{
    for (int k = 0; k < 26; k++)
        for (int bit = 0; bit < 8; bit++) {
            if (!(ext_mask[k] & (1u << bit)))
                continue;
            avr_irq_t *irq = avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ('A' + k), bit);
            uint32_t level = (ext_value[k] >> bit) & 1u;
            avr_raise_irq(irq, !level);
            avr_raise_irq(irq, level);
        }
}

static uint64_t cycle_offset; /* keeps simulated time monotonic should a reset rewind avr->cycle */

static double sim_seconds(void)
{
    return (double)(avr->cycle + cycle_offset) / avr->frequency;
}

static void (*core_reset)(avr_t *);
static int reset_seen;

static void reset_hook(avr_t *a)
{
    if (core_reset)
        core_reset(a);
    reset_seen = 1;
}

static void command(char *line)
{
    char port;
    int ch, mv, bit, level;

    if (sscanf(line, "adc %d %d", &ch, &mv) == 2 && ch >= 0 && ch < 8 && mv >= 0) {
        avr_raise_irq(avr_io_getirq(avr, AVR_IOCTL_ADC_GETIRQ, ADC_IRQ_ADC0 + ch), (uint32_t)mv);
        reply("ok adc %d %d", ch, mv);
    } else if (sscanf(line, "pin %c %d %d", &port, &bit, &level) == 3 && bit >= 0 && bit < 8) {
        avr_irq_t *irq = avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ(port), bit);
        if (!irq) {
            reply("error no port %c", port);
            return;
        }
        /* Also the port's "external" default: simavr applies it whenever the firmware makes
         * the pin an input, so the level survives a reset like a real pull-up or switch. */
        int k = port - 'A';
        if (k >= 0 && k < 26) {
            ext_mask[k] |= (uint8_t)(1u << bit);
            ext_value[k] = (uint8_t)((ext_value[k] & ~(1u << bit)) | ((level ? 1u : 0u) << bit));
            avr_ioport_external_t e = { .name = (unsigned char)port, .mask = ext_mask[k],
                                        .value = ext_value[k] };
            avr_ioctl(avr, AVR_IOCTL_IOPORT_SET_EXTERNAL(port), &e);
        }
        avr_raise_irq(irq, level ? 1 : 0);
        reply("ok pin %c %d %d", port, bit, level ? 1 : 0);
    } else if (strcmp(line, "run") == 0) {
        running = 1;
        reply("ok run");
    } else if (strcmp(line, "time") == 0) {
        reply("ok time %.0f", sim_seconds() * 1e6);
    } else if (strcmp(line, "quit") == 0) {
        quitting = 1;
        reply("ok quit");
    } else {
        reply("error unknown command: %s", line);
    }
}

static void read_stdin(void)
{
    ssize_t n = read(STDIN_FILENO, cmd_buf + cmd_len, sizeof cmd_buf - 1 - cmd_len);
    if (n <= 0) {
        quitting = 1; /* the test went away */
        return;
    }
    cmd_len += (size_t)n;
    char *nl;
    while ((nl = memchr(cmd_buf, '\n', cmd_len))) {
        *nl = 0;
        command(cmd_buf);
        size_t used = (size_t)(nl + 1 - cmd_buf);
        memmove(cmd_buf, nl + 1, cmd_len - used);
        cmd_len -= used;
    }
    if (cmd_len == sizeof cmd_buf - 1)
        cmd_len = 0; /* an overlong line: drop it */
}

/* ---- pacing ---- */

static double wall_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + ts.tv_nsec * 1e-9;
}

/* The core advances avr->cycle over sleeps by itself; simavr's default callback would also
 * usleep in real time, which --speed replaces. */
static void sleep_hook(avr_t *a, avr_cycle_count_t how_long)
{
    (void)a, (void)how_long;
}

static void service(int timeout_ms)
{
    struct pollfd p[2] = { { STDIN_FILENO, POLLIN, 0 }, { master_fd, POLLIN, 0 } };
    if (poll(p, 2, timeout_ms) > 0) {
        if (p[0].revents & (POLLIN | POLLHUP))
            read_stdin();
        if (p[1].revents & POLLIN)
            read_pty();
    }
    feed_uart();
}

int main(int argc, char **argv)
{
    const char *mcu = "atmega328p", *elf = NULL;
    uint32_t freq = 16000000, vcc = 5000;

    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--mcu") && i + 1 < argc)
            mcu = argv[++i];
        else if (!strcmp(argv[i], "--freq") && i + 1 < argc)
            freq = (uint32_t)strtoul(argv[++i], NULL, 0);
        else if (!strcmp(argv[i], "--vcc") && i + 1 < argc)
            vcc = (uint32_t)strtoul(argv[++i], NULL, 0);
        else if (!strcmp(argv[i], "--speed") && i + 1 < argc)
            speed = strtod(argv[++i], NULL);
        else if (argv[i][0] != '-' && !elf)
            elf = argv[i];
        else {
            fprintf(stderr, "usage: %s [--mcu M] [--freq HZ] [--vcc MV] [--speed X] FIRMWARE.elf\n",
                    argv[0]);
            return 2;
        }
    }
    if (!elf) {
        fprintf(stderr, "harness: no firmware given\n");
        return 2;
    }

    out = fdopen(dup(STDOUT_FILENO), "w");
    if (!out || dup2(STDERR_FILENO, STDOUT_FILENO) < 0) {
        perror("harness: stdout");
        return 1;
    }

    elf_firmware_t fw;
    memset(&fw, 0, sizeof fw);
    if (elf_read_firmware(elf, &fw)) {
        fprintf(stderr, "harness: cannot read %s\n", elf);
        return 1;
    }
    avr = avr_make_mcu_by_name(mcu);
    if (!avr) {
        fprintf(stderr, "harness: unknown mcu %s\n", mcu);
        return 1;
    }
    avr_init(avr);
    avr->log = LOG_ERROR; /* stdout belongs to the command protocol */
    fw.frequency = freq;
    fw.vcc = fw.avcc = fw.aref = vcc;
    avr_load_firmware(avr, &fw);
    avr->sleep = sleep_hook;
    core_reset = avr->reset;
    avr->reset = reset_hook;

    char path[128];
    if (open_pty(path, sizeof path)) {
        perror("harness: pty");
        return 1;
    }
    uart_connect();
    reply("pty %s", path);

    double t0 = 0, sim0 = 0;
    while (!quitting) {
        if (!running) {
            service(-1);
            t0 = wall_now();
            sim0 = sim_seconds();
            continue;
        }
        for (int i = 0; i < 2000; i++) {
            uint64_t before = avr->cycle;
            int state = avr_run(avr);
            if (state == cpu_Done || state == cpu_Crashed) {
                reply("exit %s", state == cpu_Done ? "done" : "crashed");
                return state == cpu_Done ? 0 : 1;
            }
            if (reset_seen || avr->cycle < before) {
                reset_seen = 0;
                if (avr->cycle < before)
                    cycle_offset += before - avr->cycle;
                redrive_pins();
                reply("reset at %.0f", sim_seconds() * 1e6);
            }
        }
        int wait_ms = 0;
        if (speed > 0) {
            double ahead = (sim_seconds() - sim0) / speed - (wall_now() - t0);
            if (ahead > 0.001)
                wait_ms = (int)(ahead * 1000);
        }
        service(wait_ms);
    }
    return 0;
}
