/* cmd_report.c -- `raytraffic report` (not yet implemented). */
#include "cmd.h"

#include <stdio.h>
#include <string.h>

int main_report(int argc, char **argv)
{
    if (argc > 1 && (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h"))) {
        printf("Usage: raytraffic report (not yet implemented)\n");
        return RT_EXIT_OK;
    }
    rt_cmd_error("report", "not yet implemented");
    return RT_EXIT_FAIL;
}
