/* Unity's output on the ATmega328P for the simavr runs: USART0, 115200 baud at 16 MHz (U2X),
 * polled, no Arduino core (the suites' own main()). At the end of a run: wait for the last
 * byte to leave, write the end marker 3 to GPIOR0 (unity_sim.c stops there), then sleep with
 * interrupts off. */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>

#include "../unity_output.h"

void hpddo_unity_putchar(int c) {
  static unsigned char ready;
  if (!ready) {
    UBRR0H = 0;
    UBRR0L = 16; /* 16 MHz / (8 * 117647): 115200 baud with U2X, 2.1 % off */
    UCSR0A = _BV(U2X0);
    UCSR0B = _BV(TXEN0);
    UCSR0C = 3 << UCSZ00; /* 8N1 */
    ready = 1;
  }
  while (!(UCSR0A & _BV(UDRE0))) {
  }
  UDR0 = (char)c;
  UCSR0A |= _BV(TXC0); /* clears "transmit complete": done() waits for this byte to leave */
}

void hpddo_unity_done(void) {
  while (!(UCSR0A & _BV(TXC0))) {
  }
  GPIOR0 = 3;
  cli();
  sleep_enable();
  sleep_cpu();
}
