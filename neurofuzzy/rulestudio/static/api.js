// Talking to the studio's server: JSON in, JSON out, the run's token when there is one.
const token = new URLSearchParams(location.search).get("token");

export class ApiError extends Error {
  constructor(message, detail) { super(message); this.detail = detail || {}; }
}

export async function call(path, body) {
  const options = { headers: {} };
  if (token) options.headers["X-Studio-Token"] = token;
  if (body !== undefined) {
    options.method = "POST";
    options.headers["Content-Type"] = "application/json";
    options.body = JSON.stringify(body);
  }
  const response = await fetch(path, options);
  let data = null;
  try { data = await response.json(); } catch (_) { data = { error: await response.text() }; }
  if (!response.ok) throw new ApiError((data && data.error) || response.statusText, data);
  return data;
}

export function query(path, params) {
  return call(path + "?" + new URLSearchParams(params).toString());
}
