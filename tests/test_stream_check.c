/*
 * test_stream_check.c -- the stream tracers' check on simulated cores (S7
 * of tracegen/stream.c) can fail: a pass's kernel work charged by the
 * core whose chunk holds the slot passes at the barrier; the same work
 * charged while another core's recorder is current (a loop that did not
 * switch to the slot's core) fails naming S7 and the cores' C4. The
 * tracer file is compiled into this test (its functions are static) under
 * other names for its registry entries.
 */
#define rt_tracer_stream_branching rt_tracer_stream_branching_under_test
#define rt_tracer_stream_multipass rt_tracer_stream_multipass_under_test
#include "../tracegen/stream.c"

#include "check.h"

int main(void)
{
    rt_err e = {0};
    rt_render_opts o;
    rt_render_default_opts(&o);
    rt_tracer_ctx ctx = {NULL, NULL, NULL, &o, NULL, NULL, NULL, 1, NULL, 0, 1, NULL, NULL};
    rt_cores c;
    CHECK(rt_cores_init(&c, 3, NULL, &e) == 0, "cores: %s", e.msg);
    st_run S;
    memset(&S, 0, sizeof S);
    S.ctx = &ctx;
    S.o = &o;
    S.multipass = 1;
    S.cores = &c;
    S.ncores = 3;
    /* a stream of 10 rays on 3 cores: chunks 0-2, 3-5, 6-9 */
    for (uint32_t i = 0; i < 10; i++) {
        st_slot(&S, i, 10);
        charge(&S, RT_SK_STEP, i);
    }
    st_pass_end(&S);
    CHECK(S.err == 0 && c.phases == 1, "a pass charged by its chunks' cores: err %d, %s", S.err, S.cerr.msg);
    CHECK(S.kexec[RT_SK_STEP] == 10, "%" PRIu64 " kernel calls", S.kexec[RT_SK_STEP]);
    /* slot 7 charged with core 0's recorder current */
    st_slot(&S, 0, 10);
    charge(&S, RT_SK_STEP, 7);
    st_pass_end(&S);
    CHECK(S.err == 3 && strstr(S.cerr.msg, "C4") && strstr(S.cerr.msg, "item 7 of 10 by core 0"),
          "slot 7 charged by core 0: err %d, '%s'", S.err, S.cerr.msg);
    rt_cores_free(&c);
    return failures ? 1 : 0;
}
