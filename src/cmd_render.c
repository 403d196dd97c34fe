/* cmd_render.c -- `raytraffic render` (not yet implemented). */
#include "cmd.h"

#include <stdio.h>
#include <string.h>

int main_render(int argc, char **argv)
{
    if (argc > 1 && (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h"))) {
        printf("Usage: raytraffic render (not yet implemented)\n");
        return RT_EXIT_OK;
    }
    rt_cmd_error("render", "not yet implemented");
    return RT_EXIT_FAIL;
}
