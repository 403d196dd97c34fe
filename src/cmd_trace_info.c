/* cmd_trace_info.c -- `raytraffic trace-info` (not yet implemented). */
#include "cmd.h"

#include <stdio.h>
#include <string.h>

int main_trace_info(int argc, char **argv)
{
    if (argc > 1 && (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h"))) {
        printf("Usage: raytraffic trace-info (not yet implemented)\n");
        return RT_EXIT_OK;
    }
    rt_cmd_error("trace-info", "not yet implemented");
    return RT_EXIT_FAIL;
}
