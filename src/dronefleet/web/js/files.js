// Files from the ground (map tiles, pictures, zips) fetched with the page's credentials: an <img>
// or a link cannot send them, so the bytes come through fetch() and are shown from blob: URLs
// (the Content-Security-Policy's img-src allows blob:).
import { ApiError, authHeaders } from "./api.js";

/** The file at /api/v1`path` as a Blob; an ApiError with the server's reason otherwise. */
export async function apiBlob(path) {
  let response;
  try {
    response = await fetch(`/api/v1${path}`, { headers: authHeaders() });
  } catch (err) {
    throw new ApiError(0, `the server does not answer (${err.message})`);
  }
  if (!response.ok) {
    let reason = response.statusText;
    try { reason = (await response.json()).detail || reason; } catch { /* not JSON */ }
    throw new ApiError(response.status, reason);
  }
  return response.blob();
}

/** Save `blob` as a download called `name`. */
export function saveBlob(blob, name) {
  const url = URL.createObjectURL(blob);
  const link = document.createElement("a");
  link.href = url;
  link.download = name;
  document.body.append(link);
  link.click();
  link.remove();
  setTimeout(() => URL.revokeObjectURL(url), 60000);
}
