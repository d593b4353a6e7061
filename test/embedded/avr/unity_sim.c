/* Runs one Unity suite built for the ATmega328P (test/embedded, unity_avr.c) in libsimavr:
 * prints what the firmware wrote on USART0, stops at the end marker (3 written to GPIOR0) or
 * after max_seconds of simulated time, and prints the cycles. Exit 0 only when the marker
 * was seen and Unity reported success ("\nOK" after its summary line).
 * usage: unity_sim <elf> [max_seconds] */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "avr_uart.h"
#include "sim_avr.h"
#include "sim_elf.h"
#include "sim_io.h"

enum { kGpior0 = 0x3E };

static int g_done;
static char g_out[1 << 16];
static size_t g_n;

static void on_gpior0(struct avr_t* avr, avr_io_addr_t addr, uint8_t v, void* param) {
  (void)param;
  avr->data[addr] = v;
  if (v == 3) g_done = 1;
}

static void on_uart(struct avr_irq_t* irq, uint32_t v, void* param) {
  (void)irq;
  (void)param;
  if (g_n + 1 < sizeof g_out) g_out[g_n++] = (char)v;
}

int main(int argc, char** argv) {
  if (argc < 2) {
    fprintf(stderr, "usage: %s <elf> [max_seconds]\n", argv[0]);
    return 2;
  }
  const double max_s = argc > 2 ? atof(argv[2]) : 60.0;
  elf_firmware_t fw;
  memset(&fw, 0, sizeof fw);
  if (elf_read_firmware(argv[1], &fw) != 0) {
    fprintf(stderr, "unity_sim: cannot read %s\n", argv[1]);
    return 2;
  }
  avr_t* avr = avr_make_mcu_by_name("atmega328p");
  if (!avr) return 2;
  avr_init(avr);
  avr_load_firmware(avr, &fw);
  avr->frequency = 16000000;
  avr->log = LOG_ERROR;
  avr_register_io_write(avr, kGpior0, on_gpior0, NULL);
  /* simavr sleeps on every poll of UCSR0A by default (a run then takes seconds) and echoes
   * the UART to stdout: both off, the output is printed once at the end. */
  uint32_t flags = 0;
  avr_ioctl(avr, AVR_IOCTL_UART_GET_FLAGS('0'), &flags);
  flags &= ~(uint32_t)(AVR_UART_FLAG_POLL_SLEEP | AVR_UART_FLAG_STDIO);
  avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
  avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT), on_uart, NULL);
  const avr_cycle_count_t limit = (avr_cycle_count_t)(16e6 * max_s);
  int state = cpu_Running;
  while (!g_done && state != cpu_Done && state != cpu_Crashed && avr->cycle < limit) state = avr_run(avr);
  g_out[g_n] = 0;
  fputs(g_out, stdout);
  printf("\n[unity_sim] %llu cycles (%.3f s at 16 MHz), end marker %s, cpu state %d\n",
         (unsigned long long)avr->cycle, (double)avr->cycle / 16e6, g_done ? "seen" : "NOT seen", state);
  return (g_done && strstr(g_out, "\nOK")) ? 0 : 1;
}
