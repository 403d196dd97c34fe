/* cmd_sim.c -- `raytraffic sim` (not yet implemented). */
#include "cmd.h"

#include <stdio.h>
#include <string.h>

int main_sim(int argc, char **argv)
{
    if (argc > 1 && (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h"))) {
        printf("Usage: raytraffic sim (not yet implemented)\n");
        return RT_EXIT_OK;
    }
    rt_cmd_error("sim", "not yet implemented");
    return RT_EXIT_FAIL;
}
