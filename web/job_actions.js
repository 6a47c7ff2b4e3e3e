// Cancel, pause, resume and remove-results, shared by the queue and the job page so both ask and report alike.

import { api } from '/ui/api.js';
import { shortId } from '/ui/format.js';
import { toast, toastError } from '/ui/notify.js';

// An action on a job: resolves to its new status, or null when the request failed (reported).
async function act(id, request, done, failed) {
  try {
    const job = await request(id);
    toast(`Job ${shortId(id)} ${done}`);
    return job;
  } catch (e) {
    toastError(e, `Could not ${failed} job ${shortId(id)}: `);
    return null;
  }
}

export const cancelJob = (id) => act(id, api.cancelJob, 'canceled.', 'cancel');
export const pauseJob = (id) => act(id, api.pauseJob, 'paused: it keeps its samples until resumed.', 'pause');
export const resumeJob = (id) => act(id, api.resumeJob, 'resumed.', 'resume');

// Resolves to true once the files are gone; asks first, because nothing brings them back.
export async function removeResults(id) {
  if (!window.confirm(`Delete the image, sample-rate map and report of job ${shortId(id)}? The job record stays.`)) return false;
  try {
    await api.deleteResults(id);
    toast(`Results of job ${shortId(id)} removed.`);
    return true;
  } catch (e) {
    toastError(e, `Could not remove the results of job ${shortId(id)}: `);
    return false;
  }
}
