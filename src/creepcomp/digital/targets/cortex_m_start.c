/* Start of a Cortex-M program run on QEMU's mps2 boards with semihosting (newlib's rdimon):
 * the vector table, the FPU switched on where there is one, .bss cleared, main's status
 * returned to QEMU, which exits with it. */
#include <stdint.h>

extern int main(void);
extern void initialise_monitor_handles(void);
extern uint32_t __bss_start__, __bss_end__, __stack_top;
void Reset_Handler(void);

static void fault(void)
{
    for (;;)
        ;
}

__attribute__((section(".vectors"), used)) void (*const vectors[16])(void) = {
    (void (*)(void))&__stack_top, Reset_Handler, fault, fault, fault, fault, fault,
    0, 0, 0, 0, fault, fault, 0, fault, fault};

static void semihosting_exit(int status)
{
    register uint32_t op __asm__("r0") = 0x18;                        /* SYS_EXIT */
    register uint32_t why __asm__("r1") = status == 0 ? 0x20026u : 0x20024u;
    __asm__ volatile("bkpt 0xab" : : "r"(op), "r"(why) : "memory");
}

void Reset_Handler(void)
{
    uint32_t *p;
#ifdef __ARM_FP
    *(volatile uint32_t *)0xE000ED88 |= 0xFu << 20;                   /* CPACR: the FPU on */
    __asm__ volatile("dsb\n\tisb");
#endif
    for (p = &__bss_start__; p < &__bss_end__; ++p)
        *p = 0;
    initialise_monitor_handles();
    semihosting_exit(main());
    for (;;)
        ;
}
