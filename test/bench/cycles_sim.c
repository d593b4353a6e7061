/*
 * Cycle counts of marked regions of an ATmega328P program in simavr (libsimavr):
 * the program writes its stage id to GPIOR1, then 1 to GPIOR0 at the start of a
 * region and 2 at its end; 3 ends the run, with a result byte in GPIOR2. Prints
 * one line per region, "stage cycles", then "done <GPIOR2>".
 *
 * usage: cycles_sim <elf> [max_seconds]
 */
#include <stdio.h>
#include <stdlib.h>

#include "sim_avr.h"
#include "sim_elf.h"
#include "sim_io.h"

#define GPIOR0_ADDR 0x3E
#define GPIOR1_ADDR 0x4A
#define GPIOR2_ADDR 0x4B

static avr_t* avr;
static avr_cycle_count_t started;
static unsigned stage;
static int open_region, done;
static unsigned result;
static long errors;

static void marker(struct avr_t* a, avr_io_addr_t addr, uint8_t v, void* param) {
  (void)addr;
  (void)param;
  if (v == 1) {
    stage = a->data[GPIOR1_ADDR];
    started = a->cycle;
    open_region = 1;
  } else if (v == 2) {
    if (!open_region) ++errors;
    /* The write to GPIOR0 takes effect at a->cycle; the start write's own cycle is
     * counted, so subtract the one cycle of the stop's OUT. */
    printf("%u %llu\n", stage, (unsigned long long)(a->cycle - started - 1));
    open_region = 0;
  } else if (v == 3) {
    result = a->data[GPIOR2_ADDR];
    done = 1;
  }
  a->data[addr] = v;
}

int main(int argc, char** argv) {
  if (argc < 2) {
    fprintf(stderr, "usage: cycles_sim <elf> [max_seconds]\n");
    return 2;
  }
  const double max_s = argc > 2 ? atof(argv[2]) : 60.0;
  elf_firmware_t fw = {{0}};
  if (elf_read_firmware(argv[1], &fw)) {
    fprintf(stderr, "cycles_sim: cannot read %s\n", argv[1]);
    return 2;
  }
  avr = avr_make_mcu_by_name("atmega328p");
  if (!avr) return 2;
  avr_init(avr);
  avr_load_firmware(avr, &fw);
  avr->frequency = 16000000;
  avr->log = LOG_ERROR;
  avr_register_io_write(avr, GPIOR0_ADDR, marker, NULL);
  const avr_cycle_count_t limit = (avr_cycle_count_t)(16e6 * max_s);
  int state = cpu_Running;
  while (!done && state != cpu_Done && state != cpu_Crashed && avr->cycle < limit) state = avr_run(avr);
  if (!done) {
    fprintf(stderr, "cycles_sim: no end marker (state %d, cycle %llu)\n", state, (unsigned long long)avr->cycle);
    return 1;
  }
  printf("done %u\n", result);
  return errors ? 1 : 0;
}
