/* Runs a corrector program built for the ATmega328P on simavr's cycle-counting core (16 MHz)
 * and feeds it a record through a mailbox in its SRAM.
 *
 * The program (creepcomp's avr_program.c.j2) writes the mailbox's address to GPIOR2:GPIOR1,
 * then signals on GPIOR0: 1 = wants a sample (this runner fills the mailbox during that write),
 * 2 = the step starts, 3 = the step ended, 4 = the output is in the mailbox, 5 = finished.
 * Mailbox: command (1 byte: 1 = a sample follows, 0 = stop), settled (1 byte), 2 spare bytes,
 * raw (4 bytes), aux (4 bytes: temperature or interval), out (4 bytes), status (1 byte).
 *
 * usage: simavr_run PROGRAM.elf IN OUT AUX|- relaxed|settled
 * IN and AUX hold 4-byte little-endian words (one per sample, in the step's argument type), OUT
 * receives the 4-byte outputs. Prints one line: samples, the largest and the mean cycles between
 * the step's markers, the deepest stack (bytes) below the caller's, and refused samples. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <simavr/sim_avr.h>
#include <simavr/sim_elf.h>
#include <simavr/sim_io.h>

#define GPIOR0 (0x1e + 0x20)
#define GPIOR1 (0x2a + 0x20)
#define GPIOR2 (0x2b + 0x20)

typedef struct {
    unsigned char *in, *aux, *out;
    long n, next, done;
    int settled, finished, in_step;
    avr_cycle_count_t start, total, largest;
    unsigned sp_start, sp_least, stack, refused;
} run_t;

static unsigned char *read_all(const char *path, long *size)
{
    FILE *f = fopen(path, "rb");
    unsigned char *buf;
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    *size = ftell(f);
    fseek(f, 0, SEEK_SET);
    buf = malloc((size_t)(*size > 0 ? *size : 1));
    if (buf && fread(buf, 1, (size_t)*size, f) != (size_t)*size) {
        free(buf);
        buf = NULL;
    }
    fclose(f);
    return buf;
}

static unsigned stack_pointer(avr_t *avr)
{
    return avr->data[R_SPL] | (avr->data[R_SPH] << 8);
}

static void signal_written(avr_t *avr, avr_io_addr_t addr, uint8_t v, void *param)
{
    run_t *run = param;
    unsigned box = avr->data[GPIOR1] | (avr->data[GPIOR2] << 8);
    avr->data[addr] = v;
    switch (v) {
    case 1:
        avr->data[box] = run->next < run->n;
        avr->data[box + 1] = (unsigned char)run->settled;
        if (run->next < run->n) {
            memcpy(&avr->data[box + 4], run->in + 4 * run->next, 4);
            if (run->aux) memcpy(&avr->data[box + 8], run->aux + 4 * run->next, 4);
            run->next++;
        }
        break;
    case 2:
        run->start = avr->cycle;
        run->sp_start = run->sp_least = stack_pointer(avr);
        run->in_step = 1;
        break;
    case 3: {
        avr_cycle_count_t spent = avr->cycle - run->start;
        run->in_step = 0;
        run->total += spent;
        if (spent > run->largest) run->largest = spent;
        if (run->sp_start - run->sp_least > run->stack) run->stack = run->sp_start - run->sp_least;
        break;
    }
    case 4:
        memcpy(run->out + 4 * run->done, &avr->data[box + 12], 4);
        run->refused += avr->data[box + 16] != 0;
        run->done++;
        break;
    case 5:
        run->finished = 1;
        break;
    }
}

int main(int argc, char **argv)
{
    elf_firmware_t fw;
    avr_t *avr;
    run_t run;
    long size, aux_size;
    int state = cpu_Running;
    FILE *f;
    if (argc != 6) {
        fprintf(stderr, "usage: %s PROGRAM.elf IN OUT AUX|- relaxed|settled\n", argv[0]);
        return 2;
    }
    memset(&run, 0, sizeof run);
    memset(&fw, 0, sizeof fw);
    run.in = read_all(argv[2], &size);
    if (!run.in || size % 4) {
        fprintf(stderr, "cannot read the samples %s\n", argv[2]);
        return 3;
    }
    run.n = size / 4;
    if (strcmp(argv[4], "-") != 0) {
        run.aux = read_all(argv[4], &aux_size);
        if (!run.aux || aux_size != size) {
            fprintf(stderr, "cannot read one word per sample from %s\n", argv[4]);
            return 3;
        }
    }
    run.out = malloc((size_t)(size > 0 ? size : 1));
    run.settled = strcmp(argv[5], "settled") == 0;
    if (elf_read_firmware(argv[1], &fw) != 0) {
        fprintf(stderr, "cannot read the program %s\n", argv[1]);
        return 3;
    }
    avr = avr_make_mcu_by_name("atmega328p");
    if (!avr) return 3;
    avr_init(avr);
    avr->frequency = 16000000;
    avr->log = 0;
    avr_load_firmware(avr, &fw);
    avr_register_io_write(avr, GPIOR0, signal_written, &run);
    while (!run.finished && state != cpu_Done && state != cpu_Crashed) {
        state = avr_run(avr);
        if (run.in_step) {
            unsigned sp = stack_pointer(avr);
            if (sp < run.sp_least) run.sp_least = sp;
        }
    }
    if (!run.finished || run.done != run.n) {
        fprintf(stderr, "the program stopped after %ld of %ld samples\n", run.done, run.n);
        return 4;
    }
    f = fopen(argv[3], "wb");
    if (!f || fwrite(run.out, 1, (size_t)size, f) != (size_t)size) return 3;
    fclose(f);
    printf("%ld %llu %.3f %u %u\n", run.n, (unsigned long long)run.largest,
           run.n ? (double)run.total / (double)run.n : 0.0, run.stack, run.refused);
    return 0;
}
