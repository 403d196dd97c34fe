/* cmd_trace_dump.c -- `raytraffic trace-dump` (not yet implemented). */
#include "cmd.h"

#include <stdio.h>
#include <string.h>

int main_trace_dump(int argc, char **argv)
{
    if (argc > 1 && (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h"))) {
        printf("Usage: raytraffic trace-dump (not yet implemented)\n");
        return RT_EXIT_OK;
    }
    rt_cmd_error("trace-dump", "not yet implemented");
    return RT_EXIT_FAIL;
}
