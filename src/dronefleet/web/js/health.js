// The ground's health (issue 26): a banner on every page while GET /api/v1/health is not ok
// (503 "degraded", with the problems: disk, broker, planner, telemetry), gone once it is ok.
// Polled, not pushed: a ground whose broker is gone cannot push over the broker either.
const POLL_MS = 4000;

/** Poll the health every few seconds and show its problems in `banner` (hidden when ok). */
export function watchHealth(banner) {
  async function poll() {
    try {
      const response = await fetch("/api/v1/health", {
        credentials: "same-origin", signal: AbortSignal.timeout(POLL_MS),
      });
      show(banner, await response.json());
    } catch {
      // The ground does not answer: the link state in the header says so already.
    }
    setTimeout(poll, POLL_MS);
  }
  poll();
}

function show(banner, health) {
  const problems = health && health.status !== "ok" ? health.problems || [] : [];
  banner.hidden = problems.length === 0;
  if (!problems.length) {
    banner.replaceChildren();
    return;
  }
  const title = document.createElement("strong");
  title.textContent = "Ground degraded: ";
  const list = problems.map((p) => `${p.what}: ${p.detail}`).join("; ");
  banner.replaceChildren(title, document.createTextNode(list));
}
