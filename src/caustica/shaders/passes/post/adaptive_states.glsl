// States of an adaptive photon cell (flux.w of its photons; caustic_trace.comp ADAPTIVE, caustic_refine.comp,
// caustic_footprint.comp): live photons are splatted, the others are not. STATE_LIVE is 0, the w every
// other photon pass writes, so photons made on a regular grid are all live.
#define STATE_LIVE 0.0
#define STATE_HELPER 1.0
#define STATE_REFINED 2.0
#define STATE_UNTRACED 3.0
